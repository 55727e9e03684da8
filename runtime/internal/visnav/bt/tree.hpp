// visnav behaviour trees — loading, validating and running a tree.
//
//   visnav::bt::NodeRegistry registry;
//   VISNAV_TRY(visnav::bt::register_builtin_nodes(registry));
//   visnav::bt::LoadOptions options;
//   options.clock = &host.clock();
//   VISNAV_ASSIGN(visnav::bt::Tree tree, visnav::bt::load_tree_file("trees/mission.xml", registry, options));
//   while (tree.tick_once() == visnav::bt::NodeStatus::running) { ... wait for the next frame ... }
//
// XML: `<root [BTCPP_format="4"] [main_tree_to_execute="ID"]>` with one or more
// `<BehaviorTree ID="...">` (one root node each), `<include path="..."/>` (path relative to
// the including file, confined to LoadOptions::include_root) and an optional
// `<TreeNodesModel>` (ignored). Scripts, pre/post-condition attributes and the typed
// blackboard: docs/bt.md. The main tree is
// LoadOptions::main_tree, else main_tree_to_execute, else the only BehaviorTree of the file.
// `<SubTree ID="X" [name=".."] [_autoremap="true"] port="{parent_key}" other="literal"/>`
// instantiates tree X with a child blackboard: `{parent_key}` remaps port <-> parent entry in
// both directions, a literal is written into the child blackboard, _autoremap exposes every
// (non-'_'-prefixed) parent entry under its own name.
//
// Loading, validation and instantiation use explicit work stacks, not recursion: XML nesting
// is capped at 100 per file by tinyxml2, SubTree nesting, expanded node count and expanded
// depth by LoadOptions' limits. Ticking and halting recurse parent -> child, but the loader
// places stack checkpoints that move deep calls onto separate stack segments, so the thread's
// stack use stays bounded at any depth (runtime/src/bt/bounded_stack.hpp).
//
// Validation happens before anything is instantiated and collects every error: malformed XML,
// wrong BTCPP_format / extra root attributes, unknown node ID, missing required port, unknown port attribute,
// bad literal for the port type, literal given to an output port, undefined or cyclic SubTree,
// wrong number of children, include errors, script syntax (with its column), unknown
// '_'-attributes, non-UTF-8 attributes, a blackboard key used with two port types, and the
// limits below. Each Diagnostic names file:line and the node path
// (paths in diagnostics are relative to the BehaviorTree that contains the element, e.g.
// "MainTree/Sequence[0]/Replay").
//
// Node paths: a node's path component is its `name` attribute when given, else
// `ID[i]` with i its index among its parent's children (for a SubTree element ID is the
// subtree's ID, e.g. "Approach[2]"); the top component is the BehaviorTree ID, and a
// SubTree's nodes continue below the SubTree node's component.
//
// Thread-safety: a Tree is ticked, halted and observed from one thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/bt/blackboard.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/host.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

/// One validation error.
struct Diagnostic {
  std::string file;       ///< file as given (or "<string>" for in-memory XML)
  int line = 0;           ///< 1-based, 0 when unknown
  std::string node_path;  ///< empty for file-level errors
  std::string message;
  /// What is wrong (parse_error, not_found for an unknown node type, unknown_key for an
  /// undeclared port, missing, invalid_value, out_of_range, limit, ...).
  ErrorCode code = ErrorCode::unspecified;

  /// "file:line: node_path: message" (omitting empty parts).
  [[nodiscard]] std::string str() const;
};

/// All diagnostics, one per line.
[[nodiscard]] std::string to_string(const std::vector<Diagnostic>& diagnostics);

/// One port value set on every node of a type, as if written in the XML: `ReplayFeatureEdge.gain=0.5`
/// replaces (or adds) the attribute `gain` of each <ReplayFeatureEdge> (and <Action ID="ReplayFeatureEdge">)
/// in every file of the tree, includes too. Used to tune primitive gains without editing trees
/// (`visnav run --port`, `visnav experiment --port`, `visnav tune`).
struct PortOverride {
  std::string node;   ///< registered node type
  std::string port;   ///< port name
  std::string value;  ///< attribute text (a literal or a {blackboard} reference)
};
/// Parses "Node.port=value"; errors name the text.
[[nodiscard]] Result<PortOverride> parse_port_override(const std::string& text);

struct LoadOptions {
  /// Time source for Sleep/Delay/Timeout and trace timestamps; must outlive the tree.
  /// nullptr: a monotonic wall clock.
  const Clock* clock = nullptr;
  /// Overrides `main_tree_to_execute` when not empty.
  std::string main_tree;
  /// Root blackboard to use (e.g. pre-filled by the host); nullptr: a new one.
  Blackboard::Ptr blackboard;
  /// For load_tree_string: directory that relative `<include path>` are resolved against
  /// (default: current directory) and the name used in diagnostics.
  std::filesystem::path base_dir;
  std::string source_name = "<string>";

  // Limits, checked at validation (before anything is instantiated) on the main tree as it
  // would be expanded; exceeding one is a diagnostic naming the limit and the SubTree chain.
  /// Deepest chain of nested SubTrees (the main tree is depth 0). `run.bt_max_subtree_depth`.
  int max_subtree_depth = 64;
  /// Nodes the expanded main tree may instantiate (SubTree nodes included). `run.bt_max_nodes`.
  std::size_t max_nodes = 100'000;
  /// Deepest node (root = 1) counted through SubTrees; a sanity bound only: tick() and
  /// halt() keep the thread's stack bounded at any depth (docs/bt.md, "Limits").
  /// `run.bt_max_tree_depth`.
  int max_tree_depth = 1'000;
  /// `<include path>` must be relative and stay inside this folder (after resolving "..",
  /// symlinks included). Empty: the folder of the main file (load_tree_file) or base_dir
  /// (load_tree_string, current directory when that is empty as well).
  std::filesystem::path include_root;
  /// Applied to every file as it is parsed, before validation (so a port the node does not
  /// have is the usual unknown-port diagnostic). An override whose node type appears nowhere in
  /// the loaded files is a diagnostic too (code not_found): a misspelt node is never ignored.
  std::vector<PortOverride> port_overrides;
};

class Tree;
namespace detail { struct TreeBuilder; }

/// Parses, validates (all errors) and instantiates. On failure the Error message is every
/// diagnostic (Diagnostic::str()), one per line; nothing has been instantiated.
[[nodiscard]] Result<Tree> load_tree_file(const std::filesystem::path& file, const NodeRegistry& registry,
                                          const LoadOptions& options = {});
[[nodiscard]] Result<Tree> load_tree_string(std::string_view xml, const NodeRegistry& registry,
                                            const LoadOptions& options = {});
/// Parses and validates only; empty when the tree would load.
[[nodiscard]] std::vector<Diagnostic> validate_tree_file(const std::filesystem::path& file,
                                                         const NodeRegistry& registry,
                                                         const LoadOptions& options = {});
[[nodiscard]] std::vector<Diagnostic> validate_tree_string(std::string_view xml, const NodeRegistry& registry,
                                                           const LoadOptions& options = {});

/// A loaded tree. Movable, not copyable. Destroying a RUNNING tree halts it first.
class Tree {
 public:
  Tree(Tree&&) noexcept;
  Tree& operator=(Tree&&) noexcept;
  Tree(const Tree&) = delete;
  Tree& operator=(const Tree&) = delete;
  ~Tree();

  /// One tick of the root. Returns the root status (success/failure mean the mission ended;
  /// the next tick starts it again). A node that throws (a bug) does not take the host down:
  /// the exception is caught, the whole tree is halted (RUNNING nodes get their halt
  /// callbacks, e.g. to stop the robot), last_error() says what happened and failure is returned.
  NodeStatus tick_once();
  /// Ticks until the root is not RUNNING, sleeping `sleep` (wall time) between ticks.
  NodeStatus tick_while_running(std::chrono::nanoseconds sleep = std::chrono::milliseconds(10));
  /// Halts every RUNNING node (their halt callbacks run) and resets the tree to IDLE.
  void halt();

  [[nodiscard]] NodeStatus status() const noexcept;
  /// Message of the last exception caught by tick_once() (empty if none).
  [[nodiscard]] const std::string& last_error() const noexcept { return last_error_; }
  /// Last pre/post-condition script that failed to evaluate ("file:line: path: _skipIf:
  /// column C: variable 'x' is not set"); empty if none. Such a pre-condition yields FAILURE.
  [[nodiscard]] const std::string& last_script_error() const noexcept { return context_->last_script_error; }
  [[nodiscard]] TreeNode& root() const noexcept { return *root_; }
  /// ID of the BehaviorTree that was instantiated as the main tree.
  [[nodiscard]] const std::string& main_tree_id() const noexcept { return main_tree_id_; }
  [[nodiscard]] Blackboard& blackboard() const noexcept { return *blackboard_; }
  [[nodiscard]] const Blackboard::Ptr& blackboard_ptr() const noexcept { return blackboard_; }
  [[nodiscard]] const Clock& clock() const noexcept;
  [[nodiscard]] std::size_t node_count() const noexcept { return nodes_.size(); }

  /// Depth-first, parents before children, children in order.
  void visit(const std::function<void(TreeNode&)>& visitor) const;
  /// Node with this exact path, or nullptr.
  [[nodiscard]] TreeNode* find_node(std::string_view path) const;

  /// Adds a status-change observer; returns its id for remove_observer().
  std::uint64_t add_observer(StatusObserver observer);
  void remove_observer(std::uint64_t id);

 private:
  friend struct detail::TreeBuilder;
  friend class TraceWriter;
  Tree();
  void halt_after_exception() noexcept;

  std::unique_ptr<detail::TreeContext> context_;
  std::vector<std::unique_ptr<TreeNode>> nodes_;
  TreeNode* root_ = nullptr;
  Blackboard::Ptr blackboard_;
  std::string main_tree_id_;
  std::string last_error_;
};

/// Writes every status transition of a tree as a JSON line
///   {"t":12.500000,"node":"MainTree/Sequence[0]/Replay","from":"IDLE","to":"RUNNING"}
/// `t` is seconds on the tree's clock. Lines are buffered; flushed on flush() and destruction.
/// The tree must outlive the writer (the destructor detaches from it).
class TraceWriter {
 public:
  /// Opens (truncates) `file` and starts observing `tree`.
  [[nodiscard]] static Result<std::unique_ptr<TraceWriter>> attach(Tree& tree, const std::filesystem::path& file);
  ~TraceWriter();
  TraceWriter(const TraceWriter&) = delete;
  TraceWriter& operator=(const TraceWriter&) = delete;

  void flush();
  [[nodiscard]] std::uint64_t lines_written() const noexcept { return lines_; }

 private:
  TraceWriter(Tree& tree, std::FILE* file);
  void write(double t_s, const TreeNode& node, NodeStatus from, NodeStatus to);

  detail::TreeContext* context_;
  std::FILE* file_;
  std::uint64_t observer_id_ = 0;
  std::uint64_t lines_ = 0;
};

}  // namespace visnav::bt
