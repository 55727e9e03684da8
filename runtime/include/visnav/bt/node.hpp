// visnav behaviour trees — nodes and the base classes for writing them.
//
// A primitive is a small class deriving from one of
//  * SyncActionNode      — `tick()` does the work and returns success or failure;
//  * StatefulActionNode  — `on_start()` / `on_running()` return running until done,
//                          `on_halted()` is called when a RUNNING node is interrupted;
//  * ConditionNode       — `tick()` returns success or failure, no side effects;
//  * ControlNode / DecoratorNode — for new control flow (children are ticked with
//                          `execute_tick()` and stopped with `halt_child...()`).
// Every node type provides `static PortsList provided_ports()` and a constructor
// `(const std::string& name, const NodeConfig& config)` (extra constructor arguments are fine
// when the node is registered with a factory lambda).
//
//   class Drive : public visnav::bt::StatefulActionNode {
//    public:
//     Drive(const std::string& name, const visnav::bt::NodeConfig& config) : StatefulActionNode(name, config) {}
//     static visnav::bt::PortsList provided_ports() {
//       return {visnav::bt::input_port<double>("speed_mps", "0.3", "forward speed")};
//     }
//     visnav::bt::NodeStatus on_start() override { ... return NodeStatus::running; }
//     visnav::bt::NodeStatus on_running() override { ... }
//     void on_halted() override { ... stop the robot ... }
//   };
//
// Status and halting (BehaviorTree.CPP v4 semantics): `execute_tick()` calls `tick()` and stores
// the returned status (a node must not return idle; that is reported as failure).
// `halt_node()` calls `halt()` only if the node is RUNNING, then resets the status to IDLE.
// Status changes are reported to the tree's observers (trace, telemetry).
// tick() and the on_* callbacks must not throw (report problems by returning failure, e.g.
// when get_input() fails; a throw is a bug: Tree::tick_once() catches it and halts the whole
// tree); a SyncActionNode or ConditionNode must not return running.
//
// Ownership: a Tree owns all its nodes; parents hold non-owning pointers to their children.
// Thread-safety: a tree and its nodes are used from one thread (the tick thread).
#pragma once

#include <any>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/bt/blackboard.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/config_node.hpp"
#include "visnav/host.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

class TreeNode;
struct NodeManifest;  // visnav/bt/registry.hpp

/// A node's path, stored as its last component plus a shared pointer to the parent's path, so
/// a tree of N nodes keeps O(N) path text whatever its depth. Immutable once built.
struct NodePath {
  std::shared_ptr<const NodePath> parent;
  std::string component;  ///< `name` attribute, or `ID[index]`; the top one is the BehaviorTree ID

  /// "MainTree/Sequence[0]/Replay" (components joined with '/'); O(depth).
  [[nodiscard]] std::string str() const;
  /// Releases the chain of parents that only this path holds iteratively (a chain as long as
  /// the tree is deep must not unwind through one destructor call per level).
  ~NodePath();
  [[nodiscard]] static std::shared_ptr<const NodePath> make(std::shared_ptr<const NodePath> parent,
                                                            std::string component);
};

/// Called on every status change of every node of a tree: time on the tree's clock (s),
/// the node, old and new status. Runs synchronously on the tick thread; keep it cheap.
using StatusObserver = std::function<void(double t_s, const TreeNode& node, NodeStatus from, NodeStatus to)>;

namespace detail {
class StackSegments;  // runtime-internal
struct NodeAccess;    // runtime-internal: calls tick()/halt()/set_status() for the engine
/// State shared by all nodes of one tree (owned by the Tree).
struct TreeContext {
  const Clock* clock = nullptr;
  std::shared_ptr<const EnumTables> enums;
  std::vector<std::pair<std::uint64_t, StatusObserver>> observers;
  std::uint64_t next_observer_id = 1;
  std::string last_script_error;  ///< last failed pre/post-condition script (file:line: path: attr: message)
  /// Keeps tick/halt stack use bounded in deep trees (runtime-internal; set by the loader).
  std::shared_ptr<StackSegments> stacks;

  void notify(const TreeNode& node, NodeStatus from, NodeStatus to) const;
};
/// Pre/post-condition scripts of one node instance (`_skipIf`, `_onSuccess`, ...; see
/// docs/bt.md). Defined in the runtime; nodes only hold a pointer.
class NodeScripts;
/// Runs the node's conditions around tick() (out of line: the common no-script path stays
/// inline). Also the path of the loader's stack checkpoints (see TreeContext::stacks).
NodeStatus execute_tick_scripted(TreeNode& node, const NodeScripts& scripts);
/// halt() of a RUNNING node that has a NodeScripts, then its `_onHalted`.
void halt_scripted(TreeNode& node, const NodeScripts& scripts);
/// Monotonic wall clock used when a node is not part of a tree with a clock.
const Clock& fallback_clock() noexcept;
}  // namespace detail

/// The value of one port of one node instance, as resolved at load time.
struct PortBinding {
  enum class Source : std::uint8_t {
    none,        ///< not given in XML and no default (only possible for output ports)
    literal,     ///< constant, parsed once at load time into `literal`
    blackboard,  ///< `{key}` / `{@key}` / `{=}`: read/written through the blackboard
  };

  std::string name;
  PortDirection direction = PortDirection::input;
  Source source = Source::none;
  std::string text;        ///< as written in XML (or the default)
  std::string key;         ///< blackboard key for Source::blackboard ('@' prefix = root)
  std::any literal;        ///< parsed literal for Source::literal (type of the port)
  bool from_default = false;
  mutable Blackboard::Entry* cached_entry = nullptr;  ///< resolved once the entry exists
};

/// Everything a node instance is constructed with. Built by the tree loader.
struct NodeConfig {
  std::string id;                 ///< registration ID ("Sequence", "Replay", ...)
  std::shared_ptr<const NodePath> path;  ///< full node path, e.g. "MainTree/Sequence[0]/Replay"
  SourceLocation where;           ///< XML file and line of the element
  Blackboard::Ptr blackboard;     ///< the blackboard of the (sub)tree the node is in
  std::vector<PortBinding> ports; ///< one per declared port, declaration order
  std::shared_ptr<const NodeManifest> manifest;
  detail::TreeContext* context = nullptr;  ///< owned by the Tree; nullptr outside a tree
  std::shared_ptr<const detail::NodeScripts> scripts;  ///< pre/post conditions; nullptr when none
};

class TreeNode {
 public:
  TreeNode(const std::string& name, const NodeConfig& config);
  virtual ~TreeNode() = default;
  TreeNode(const TreeNode&) = delete;
  TreeNode& operator=(const TreeNode&) = delete;

  /// Instance name: the XML `name` attribute, or the registration ID.
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] const std::string& registration_id() const noexcept { return config_.id; }
  /// Full path ("MainTree/Sequence[0]/Replay"), built on each call from the shared
  /// NodePath (empty when the node was made outside a tree).
  [[nodiscard]] std::string path() const { return config_.path ? config_.path->str() : std::string(); }
  [[nodiscard]] const SourceLocation& where() const noexcept { return config_.where; }
  [[nodiscard]] NodeStatus status() const noexcept { return status_; }
  [[nodiscard]] virtual NodeKind kind() const noexcept = 0;
  /// Children in order (empty for leaves).
  [[nodiscard]] virtual std::span<TreeNode* const> children() const noexcept { return {}; }
  [[nodiscard]] const NodeConfig& config() const noexcept { return config_; }

  /// Ticks the node: calls tick(), stores and returns the new status. Called by parents/Tree.
  NodeStatus execute_tick() {
    if (config_.scripts != nullptr) [[unlikely]]
      return detail::execute_tick_scripted(*this, *config_.scripts);
    NodeStatus s = tick();
    if (s == NodeStatus::idle) [[unlikely]] s = NodeStatus::failure;
    set_status(s);
    return s;
  }
  /// Interrupts the node: halt() if RUNNING, then status IDLE.
  void halt_node() {
    if (status_ == NodeStatus::running) {
      if (config_.scripts != nullptr) [[unlikely]] {
        detail::halt_scripted(*this, *config_.scripts);
      } else {
        halt();
      }
    }
    set_status(NodeStatus::idle);
  }
  /// Sets the status to IDLE without calling halt().
  void reset_status() { set_status(NodeStatus::idle); }

  /// Reads input (or inout) port `port` as T: a cached literal, or the blackboard entry it
  /// references (converted per Blackboard rules). The error names the node path and the port.
  /// Allocation-free on success for literal and blackboard ports of non-allocating types.
  template <typename T>
  [[nodiscard]] Result<T> get_input(std::string_view port) const;

  /// Writes output (or inout) port `port`, which must reference a blackboard entry.
  template <typename T>
  Status set_output(std::string_view port, T value);

  /// Binding of a declared port, or nullptr.
  [[nodiscard]] const PortBinding* port(std::string_view name) const noexcept {
    for (const PortBinding& b : config_.ports)
      if (b.name == name) return &b;
    return nullptr;
  }

  [[nodiscard]] Blackboard& blackboard() const noexcept { return *config_.blackboard; }
  [[nodiscard]] const Clock& clock() const noexcept {
    return config_.context != nullptr && config_.context->clock != nullptr ? *config_.context->clock
                                                                             : detail::fallback_clock();
  }
  [[nodiscard]] const EnumTables* enums() const noexcept {
    return config_.context != nullptr ? config_.context->enums.get() : config_.blackboard->enums();
  }

 protected:
  friend NodeStatus detail::execute_tick_scripted(TreeNode&, const detail::NodeScripts&);
  friend void detail::halt_scripted(TreeNode&, const detail::NodeScripts&);
  friend struct detail::NodeAccess;
  /// The node's work for one tick. Must not return idle.
  virtual NodeStatus tick() = 0;
  /// Stops asynchronous work. Called by halt_node() only while the node is RUNNING.
  virtual void halt() {}

  void set_status(NodeStatus s) {
    if (s == status_) return;
    const NodeStatus old = status_;
    status_ = s;
    if (config_.context != nullptr && !config_.context->observers.empty()) [[unlikely]]
      config_.context->notify(*this, old, s);
  }

 private:
  [[nodiscard]] Error port_error(std::string_view port, std::string_view message) const;
  [[nodiscard]] const Blackboard::Entry* input_entry(const PortBinding& b) const;
  [[nodiscard]] Blackboard::Entry* output_entry(const PortBinding& b);

  std::string name_;
  NodeConfig config_;
  NodeStatus status_ = NodeStatus::idle;
};

/// Base of every action (kind "Action").
class ActionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  [[nodiscard]] NodeKind kind() const noexcept final { return NodeKind::action; }
};

/// Synchronous action: tick() returns success or failure (never running).
class SyncActionNode : public ActionNode {
 public:
  using ActionNode::ActionNode;
};

/// Action that runs over several ticks.
///  * first tick (status IDLE): on_start(); return running to continue, or finish immediately;
///  * later ticks while RUNNING: on_running();
///  * interrupted while RUNNING: on_halted() (then the status becomes IDLE).
class StatefulActionNode : public ActionNode {
 public:
  using ActionNode::ActionNode;

  virtual NodeStatus on_start() = 0;
  virtual NodeStatus on_running() = 0;
  virtual void on_halted() = 0;

 protected:
  NodeStatus tick() final { return status() == NodeStatus::running ? on_running() : on_start(); }
  void halt() final { on_halted(); }
};

/// Condition (kind "Condition"): tick() returns success or failure, without side effects.
class ConditionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  [[nodiscard]] NodeKind kind() const noexcept final { return NodeKind::condition; }
};

/// Node with one or more children (kind "Control").
class ControlNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  [[nodiscard]] NodeKind kind() const noexcept final { return NodeKind::control; }
  [[nodiscard]] std::span<TreeNode* const> children() const noexcept final { return children_; }
  /// Appends a child (the tree keeps ownership). Used by the loader.
  void add_child(TreeNode* child) { children_.push_back(child); }
  [[nodiscard]] std::size_t children_count() const noexcept { return children_.size(); }

 protected:
  /// Default halt: halt/reset all children.
  void halt() override { reset_children(); }
  /// Halts child i if RUNNING, then sets it IDLE.
  void halt_child(std::size_t i) { children_[i]->halt_node(); }
  /// halt_child for every child from index `first` on.
  void halt_children(std::size_t first = 0) {
    for (std::size_t i = first; i < children_.size(); ++i) children_[i]->halt_node();
  }
  /// halt_children(0): after this every child is IDLE.
  void reset_children() { halt_children(0); }

  std::vector<TreeNode*> children_;
};

/// Node with exactly one child (kind "Decorator").
class DecoratorNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  [[nodiscard]] NodeKind kind() const noexcept override { return NodeKind::decorator; }
  [[nodiscard]] std::span<TreeNode* const> children() const noexcept final {
    return child_ != nullptr ? std::span<TreeNode* const>(&child_, 1) : std::span<TreeNode* const>();
  }
  /// Sets the child (the tree keeps ownership). Used by the loader.
  void set_child(TreeNode* child) noexcept { child_ = child; }
  [[nodiscard]] TreeNode* child() const noexcept { return child_; }

 protected:
  void halt() override { halt_child(); }
  /// Halts the child if RUNNING, then sets it IDLE.
  void halt_child() { child_->halt_node(); }
  void reset_child() { child_->halt_node(); }

  TreeNode* child_ = nullptr;
};

// ---------------------------------------------------------------------------------------------

template <typename T>
Result<T> TreeNode::get_input(std::string_view port_name) const {
  const PortBinding* b = port(port_name);
  if (b == nullptr) [[unlikely]]
    return port_error(port_name, "is not a declared port of " + config_.id);
  switch (b->source) {
    case PortBinding::Source::literal: {
      if (const T* v = std::any_cast<T>(&b->literal)) [[likely]]
        return *v;
      auto r = PortConverter<T>::parse(b->text, enums());
      if (!r) return port_error(port_name, r.error().message);
      return r;
    }
    case PortBinding::Source::blackboard: {
      const Blackboard::Entry* e = input_entry(*b);
      if (e == nullptr || !e->value.has_value())
        return port_error(port_name, "blackboard key '" + b->key + "' is not set");
      if (const T* v = std::any_cast<T>(&e->value)) [[likely]]
        return *v;
      auto r = detail::any_to<T>(e->value, enums());
      if (!r) return port_error(port_name, "blackboard key '" + b->key + "' " + r.error().message);
      return r;
    }
    case PortBinding::Source::none:
      break;
  }
  return port_error(port_name, "has no value (not set in the XML and no default)");
}

template <typename T>
Status TreeNode::set_output(std::string_view port_name, T value) {
  const PortBinding* b = port(port_name);
  if (b == nullptr) [[unlikely]]
    return port_error(port_name, "is not a declared port of " + config_.id);
  if (b->direction == PortDirection::input) return port_error(port_name, "is an input port");
  if (b->source != PortBinding::Source::blackboard)
    return port_error(port_name, "is not connected to a blackboard entry");
  Blackboard::Entry* e = output_entry(*b);
  if constexpr (std::is_convertible_v<T, std::string_view> && !std::is_same_v<std::decay_t<T>, std::string>) {
    e->value = std::string(std::string_view(value));
  } else {
    e->value = std::move(value);
  }
  ++e->sequence;
  return ok();
}

}  // namespace visnav::bt
