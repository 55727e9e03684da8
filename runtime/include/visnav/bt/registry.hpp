// visnav behaviour trees — the registry of node types.
//
// The host creates one NodeRegistry, calls register_builtin_nodes() and then each `nodes`
// plugin's registrar
//   extern "C"-exported descriptor -> Status register_nodes(visnav::bt::NodeRegistry&, visnav::HostServices&)
// which registers its types:
//   VISNAV_TRY(registry.register_node<IsObstacleAhead>("IsObstacleAhead", "true when ..."));
//   VISNAV_TRY(registry.register_node<Replay>("Replay", "replays the current edge",
//       [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
//         return std::make_unique<Replay>(name, config, host);
//       }));
// Registering an ID twice is an error. Exceptions thrown by a factory are caught in the
// (inline, plugin-side) wrapper and returned as an Error.
//
// Ownership: manifests are shared with the trees built from them (the registry may be
// destroyed before its trees; the code of plugin nodes must stay loaded while trees live).
// Thread-safety: register everything first, then load trees; registration is not thread-safe,
// concurrent const use is.
#pragma once

#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <typeindex>
#include <utility>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

/// The input ports of one node element as a tree gives them, for a node type's own cross-port
/// rules at validation (NodeManifest::check_literals): every literal value (written or the
/// port's default, as text) and the names of the ports bound to blackboard entries, whose values
/// are known only when the node runs.
struct LiteralPorts {
  std::map<std::string, std::string, std::less<>> values;
  std::vector<std::string> bound;
  [[nodiscard]] bool is_bound(std::string_view name) const noexcept {
    for (const std::string& b : bound)
      if (b == name) return true;
    return false;
  }
};

/// Description of a registered node type.
struct NodeManifest {
  std::string id;
  NodeKind kind = NodeKind::action;
  PortsList ports;
  std::string description;
  int min_children = 0;   ///< validated at load time
  int max_children = 0;   ///< -1 = unbounded
  bool builtin = false;   ///< registered by register_builtin_nodes()
  /// Rules across ports (e.g. a params struct's validate()) checked on the literal values when a
  /// tree is validated or loaded, so `visnav validate` and `visnav run` refuse the same tree
  /// before the first tick. Must skip what depends on bound ports. Empty: none.
  std::function<Status(const LiteralPorts&)> check_literals;

  [[nodiscard]] const PortInfo* find_port(std::string_view name) const noexcept {
    for (const PortInfo& p : ports)
      if (p.name == name) return &p;
    return nullptr;
  }
};

/// Creates a node instance. Must not throw (the template overloads wrap user factories).
using NodeFactory = std::function<Result<std::unique_ptr<TreeNode>>(const std::string& name, const NodeConfig& config)>;

namespace detail {
template <typename T>
constexpr NodeKind kind_of() {
  if constexpr (std::is_base_of_v<ConditionNode, T>) return NodeKind::condition;
  else if constexpr (std::is_base_of_v<ControlNode, T>) return NodeKind::control;
  else if constexpr (std::is_base_of_v<DecoratorNode, T>) return NodeKind::decorator;
  else return NodeKind::action;
}
template <typename T>
PortsList ports_of() {
  if constexpr (requires { T::provided_ports(); }) return T::provided_ports();
  else return {};
}
/// Children range: from `static constexpr int min_children/max_children` on T, else by kind.
template <typename T>
std::pair<int, int> children_range() {
  constexpr NodeKind k = kind_of<T>();
  int lo = k == NodeKind::control ? 1 : k == NodeKind::decorator ? 1 : 0;
  int hi = k == NodeKind::control ? -1 : k == NodeKind::decorator ? 1 : 0;
  if constexpr (requires { T::min_children; }) lo = T::min_children;
  if constexpr (requires { T::max_children; }) hi = T::max_children;
  return {lo, hi};
}
template <typename T, typename F>
NodeFactory wrap_factory(F&& make) {
  return [make = std::forward<F>(make)](const std::string& name,
                                       const NodeConfig& config) noexcept -> Result<std::unique_ptr<TreeNode>> {
    try {
      std::unique_ptr<TreeNode> node = make(name, config);
      if (!node) return fail("factory returned no node");
      return node;
    } catch (const std::exception& e) {
      return fail(std::string("node factory threw an exception: ") + e.what());
    } catch (...) {
      return fail("node factory threw a non-standard exception");
    }
  };
}
}  // namespace detail

class NodeRegistry {
 public:
  NodeRegistry();

  /// Registers T under `id`, constructed as T(name, config). Kind, ports and children range
  /// come from T (see node.hpp). Fails for a duplicate ID, an invalid ID or port declaration
  /// (duplicate port name, reserved name such as "name"/"ID", bad default literal).
  template <typename T>
  Status register_node(std::string id, std::string description = {}) {
    static_assert(std::is_base_of_v<TreeNode, T>, "T must derive from visnav::bt::TreeNode");
    static_assert(std::is_constructible_v<T, const std::string&, const NodeConfig&>,
                  "T needs a constructor (const std::string& name, const NodeConfig& config); "
                  "otherwise register it with a factory");
    return register_node<T>(std::move(id), std::move(description),
                            [](const std::string& name, const NodeConfig& config) {
                              return std::make_unique<T>(name, config);
                            });
  }

  /// Registers T with a factory `(const std::string& name, const NodeConfig&) -> std::unique_ptr<T>`
  /// (e.g. a lambda capturing HostServices&).
  template <typename T, typename F>
  Status register_node(std::string id, std::string description, F&& factory) {
    static_assert(std::is_base_of_v<TreeNode, T>, "T must derive from visnav::bt::TreeNode");
    NodeManifest m;
    m.id = std::move(id);
    m.kind = detail::kind_of<T>();
    m.ports = detail::ports_of<T>();
    m.description = std::move(description);
    auto [lo, hi] = detail::children_range<T>();
    m.min_children = lo;
    m.max_children = hi;
    return register_manifest(std::move(m), detail::wrap_factory<T>(std::forward<F>(factory)));
  }

  /// Low-level registration (the factory must not throw).
  Status register_manifest(NodeManifest manifest, NodeFactory factory);

  /// Registers enum E for port conversion: literals may name a value ("fast") or give its
  /// integer. Register enums before loading trees.
  template <typename E>
  Status register_enum(std::string type_name, const std::vector<std::pair<std::string, E>>& values) {
    static_assert(std::is_enum_v<E>);
    std::vector<std::pair<std::string, int>> ints;
    ints.reserve(values.size());
    for (const auto& [n, v] : values) ints.emplace_back(n, static_cast<int>(v));
    return register_enum_values(std::type_index(typeid(E)), std::move(type_name), std::move(ints));
  }
  Status register_enum_values(std::type_index type, std::string type_name, std::vector<std::pair<std::string, int>> values);

  /// Manifest of `id`, or nullptr.
  [[nodiscard]] const NodeManifest* find(std::string_view id) const noexcept;
  [[nodiscard]] std::shared_ptr<const NodeManifest> find_shared(std::string_view id) const;
  /// All manifests sorted by ID.
  [[nodiscard]] std::vector<const NodeManifest*> manifests() const;
  [[nodiscard]] std::size_t size() const noexcept { return entries_.size(); }

  /// Creates an instance of `id`.
  [[nodiscard]] Result<std::unique_ptr<TreeNode>> instantiate(std::string_view id, const std::string& name,
                                                              const NodeConfig& config) const;

  [[nodiscard]] const std::shared_ptr<const EnumTables>& enums() const noexcept { return enums_; }

  /// While true, every registration is marked `builtin` (used by register_builtin_nodes()).
  void set_registering_builtins(bool on) noexcept { registering_builtins_ = on; }

 private:
  struct Entry {
    std::shared_ptr<const NodeManifest> manifest;
    NodeFactory factory;
  };
  std::map<std::string, Entry, std::less<>> entries_;
  std::shared_ptr<const EnumTables> enums_;
  bool registering_builtins_ = false;
};

/// Registers the BehaviorTree.CPP v4 standard nodes:
///  Controls: Sequence, SequenceWithMemory, ReactiveSequence, AsyncSequence, Fallback,
///            ReactiveFallback, AsyncFallback, Parallel, ParallelAll, IfThenElse, WhileDoElse,
///            TryCatch, ManualSelector, Switch2..Switch6.
///  Decorators: Inverter, ForceSuccess, ForceFailure, Repeat, RetryUntilSuccessful, Timeout,
///              Delay, RunOnce, KeepRunningUntilFailure, Precondition, SkipUnlessUpdated,
///              WaitValueUpdate, LoopInt, LoopDouble, LoopString, LoopBool.
///  Actions: AlwaysSuccess, AlwaysFailure, SetBlackboard, UnsetBlackboard, Sleep, Script,
///           WasEntryUpdated.  Conditions: ScriptCondition.
/// Timed nodes use the tree's Clock. Fails if one of these IDs is already registered.
Status register_builtin_nodes(NodeRegistry& registry);

/// `<root BTCPP_format="4"><TreeNodesModel>` with one `<Action|Condition|Control|Decorator ID=..>`
/// per registered type (sorted by ID), its `<input_port|output_port|inout_port name type default>`
/// elements (text: description) and the node description as `<description>` — loadable as a
/// Groot2 palette. Built-in nodes are left out unless `include_builtin`.
[[nodiscard]] std::string write_nodes_model(const NodeRegistry& registry, bool include_builtin = true);

/// The ports of one BehaviorTree used as a SubTree, for a Groot2 model: every attribute name
/// given to `<SubTree ID="id">` elements (other than ID, name and '_'-attributes), sorted.
struct SubTreeModel {
  std::string id;
  std::vector<std::string> ports;
};
/// SubTree models of the trees defined in `tree_file` and the files it includes (transitively).
/// Errors: unreadable or malformed files, naming the file.
[[nodiscard]] Result<std::vector<SubTreeModel>> subtree_models(const std::filesystem::path& tree_file);
/// write_nodes_model plus one `<SubTree ID=".."><inout_port name=".."/>...</SubTree>` per model,
/// so that Groot2 keeps the remapping attributes of SubTree elements when it saves the file.
[[nodiscard]] std::string write_nodes_model(const NodeRegistry& registry, bool include_builtin,
                                            const std::vector<SubTreeModel>& subtrees);

}  // namespace visnav::bt
