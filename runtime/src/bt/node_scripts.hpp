// Internal: the pre/post-condition scripts of a node instance (`_skipIf`, `_onSuccess`, ...).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string_view>

#include "visnav/bt/node.hpp"
#include "visnav/bt/script.hpp"

namespace visnav::bt::detail {

/// Attribute -> slot. Pre-conditions are checked in this order (as BehaviorTree.CPP does).
enum class ScriptSlot : std::uint8_t {
  failure_if, success_if, skip_if, while_true,  // pre-conditions
  on_success, on_failure, on_halted, post,      // post-conditions
  count
};

/// The slot of a condition attribute name, or nullopt.
std::optional<ScriptSlot> script_slot(std::string_view attribute) noexcept;
/// Attribute name of a slot ("_skipIf", ...).
const char* script_attribute(ScriptSlot slot) noexcept;

/// The engine's access to a node's protected tick(), halt() and set_status().
struct NodeAccess {
  static NodeStatus tick(TreeNode& node) { return node.tick(); }
  static void halt(TreeNode& node) { node.halt(); }
  static void set_status(TreeNode& node, NodeStatus s) { node.set_status(s); }
};

class NodeScripts {
 public:
  std::array<std::shared_ptr<const Script>, static_cast<std::size_t>(ScriptSlot::count)> slots;
  /// A stack checkpoint (bounded_stack.hpp): tick and halt of this node go through
  /// StackSegments::run(). Set by the loader on every kCheckpointInterval-th level.
  bool checkpoint = false;

  [[nodiscard]] const Script* get(ScriptSlot s) const noexcept { return slots[static_cast<std::size_t>(s)].get(); }
};

}  // namespace visnav::bt::detail
