// Pre/post conditions around TreeNode::tick() (BehaviorTree.CPP v4 semantics):
//  * while the node is IDLE (or was SKIPPED): _failureIf true -> FAILURE, _successIf true ->
//    SUCCESS, _skipIf true -> SKIPPED, _while false -> SKIPPED, checked in that order, and the
//    node's tick() is not called;
//  * while it is RUNNING: _while false -> the node is halted and SKIPPED;
//  * when it completes: _onSuccess or _onFailure, then _post;
//  * when a RUNNING node is halted: _onHalted.
// A script that fails to evaluate (e.g. an unset variable) makes a pre-condition return
// FAILURE; the message goes to the tree's last_script_error().
#include "node_scripts.hpp"

#include "bounded_stack.hpp"

namespace visnav::bt::detail {

namespace {
constexpr std::array<std::string_view, static_cast<std::size_t>(ScriptSlot::count)> kNames = {
    "_failureIf", "_successIf", "_skipIf", "_while", "_onSuccess", "_onFailure", "_onHalted", "_post"};

void record(TreeNode& node, ScriptSlot slot, const Error& e) {
  if (node.config().context == nullptr) return;
  node.config().context->last_script_error =
      node.where().str() + ": " + node.path() + ": " + script_attribute(slot) + ": " + e.message;
}

// Runs a script; for pre-conditions returns its truth (nullopt on error, recorded).
std::optional<bool> run(TreeNode& node, const NodeScripts& scripts, ScriptSlot slot) {
  const Script* s = scripts.get(slot);
  auto v = s->evaluate(node.blackboard(), node.enums());
  if (!v) {
    record(node, slot, v.error());
    return std::nullopt;
  }
  if (slot >= ScriptSlot::on_success) return true;
  auto t = v->truth();
  if (!t) {
    record(node, slot, t.error());
    return std::nullopt;
  }
  return *t;
}
}  // namespace

std::optional<ScriptSlot> script_slot(std::string_view attribute) noexcept {
  for (std::size_t i = 0; i < kNames.size(); ++i)
    if (kNames[i] == attribute) return static_cast<ScriptSlot>(i);
  return std::nullopt;
}

const char* script_attribute(ScriptSlot slot) noexcept {
  return slot < ScriptSlot::count ? kNames[static_cast<std::size_t>(slot)].data() : "?";
}

namespace {
NodeStatus tick_with_conditions(TreeNode& node, const NodeScripts& scripts) {
  std::optional<NodeStatus> pre;
  const NodeStatus before = node.status();
  if (before == NodeStatus::idle || before == NodeStatus::skipped) {
    for (ScriptSlot slot : {ScriptSlot::failure_if, ScriptSlot::success_if, ScriptSlot::skip_if, ScriptSlot::while_true}) {
      if (scripts.get(slot) == nullptr) continue;
      const std::optional<bool> t = run(node, scripts, slot);
      if (!t) {
        pre = NodeStatus::failure;
        break;
      }
      if (slot == ScriptSlot::while_true) {
        if (!*t) pre = NodeStatus::skipped;
      } else if (*t) {
        pre = slot == ScriptSlot::failure_if ? NodeStatus::failure
              : slot == ScriptSlot::success_if ? NodeStatus::success
                                               : NodeStatus::skipped;
      }
      if (pre) break;
    }
  } else if (before == NodeStatus::running && scripts.get(ScriptSlot::while_true) != nullptr) {
    const std::optional<bool> t = run(node, scripts, ScriptSlot::while_true);
    if (!t || !*t) {
      node.halt_node();
      pre = t ? NodeStatus::skipped : NodeStatus::failure;
    }
  }
  NodeStatus s = pre ? *pre : NodeAccess::tick(node);
  if (s == NodeStatus::idle) s = NodeStatus::failure;
  if (is_completed(s)) {
    const ScriptSlot done = s == NodeStatus::success ? ScriptSlot::on_success : ScriptSlot::on_failure;
    if (scripts.get(done) != nullptr) (void)run(node, scripts, done);
    if (scripts.get(ScriptSlot::post) != nullptr) (void)run(node, scripts, ScriptSlot::post);
  }
  NodeAccess::set_status(node, s);
  return s;
}

void halt_with_conditions(TreeNode& node, const NodeScripts& scripts) {
  NodeAccess::halt(node);
  if (scripts.get(ScriptSlot::on_halted) != nullptr) (void)run(node, scripts, ScriptSlot::on_halted);
}

StackSegments* checkpoint_stacks(const TreeNode& node, const NodeScripts& scripts) {
  if (!scripts.checkpoint || node.config().context == nullptr) return nullptr;
  return node.config().context->stacks.get();
}
}  // namespace

NodeStatus execute_tick_scripted(TreeNode& node, const NodeScripts& scripts) {
  if (StackSegments* stacks = checkpoint_stacks(node, scripts)) [[unlikely]] {
    NodeStatus s = NodeStatus::failure;
    auto body = [&] { s = tick_with_conditions(node, scripts); };
    stacks->run(body);
    return s;
  }
  return tick_with_conditions(node, scripts);
}

void halt_scripted(TreeNode& node, const NodeScripts& scripts) {
  if (StackSegments* stacks = checkpoint_stacks(node, scripts)) [[unlikely]] {
    auto body = [&] { halt_with_conditions(node, scripts); };
    stacks->run(body);
    return;
  }
  halt_with_conditions(node, scripts);
}

}  // namespace visnav::bt::detail
