// Built-in nodes around scripts and blackboard entries (BehaviorTree.CPP v4 semantics):
// Script, ScriptCondition, Precondition, UnsetBlackboard, WasEntryUpdated, SkipUnlessUpdated,
// WaitValueUpdate and the Loop<T> queue decorators.
#include <deque>

#include "builtin_internal.hpp"
#include "visnav/bt/script.hpp"

namespace visnav::bt::detail {
namespace {

using S = NodeStatus;

// Runs the script of port `port` (parsed at load time when literal; from the blackboard each
// tick otherwise). Errors go to the tree's last_script_error().
Result<ScriptValue> run_script(const TreeNode& node, std::string_view port) {
  auto code = node.get_input<ScriptCode>(port);
  if (!code) return std::move(code).error();
  auto v = code->script->evaluate(node.blackboard(), node.enums());
  if (!v) {
    if (node.config().context != nullptr)
      node.config().context->last_script_error = node.where().str() + ": " + node.path() + ": " + v.error().message;
    return std::move(v).error();
  }
  return v;
}

// Script: runs `code`; SUCCESS (FAILURE when the script fails to evaluate).
class RunScript final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {input_port<ScriptCode>("code", "script to run (assignments, ...)")}; }

 protected:
  NodeStatus tick() override { return run_script(*this, "code") ? S::success : S::failure; }
};

// ScriptCondition: SUCCESS when `code` evaluates to true.
class ScriptCondition final : public ConditionNode {
 public:
  using ConditionNode::ConditionNode;
  static PortsList provided_ports() { return {input_port<ScriptCode>("code", "boolean expression")}; }

 protected:
  NodeStatus tick() override {
    auto v = run_script(*this, "code");
    if (!v) return S::failure;
    auto t = v->truth();
    return t && *t ? S::success : S::failure;
  }
};

// Precondition: while the child is not running, `if` is evaluated: true -> tick the child,
// false -> return `else` (default FAILURE). A running child is ticked without re-evaluating.
class Precondition final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<ScriptCode>("if", "condition script"),
            input_port<NodeStatus>("else", "FAILURE", "status returned when the condition is false")};
  }

 protected:
  NodeStatus tick() override {
    if (!child_running_) {
      auto v = run_script(*this, "if");
      if (!v) return S::failure;
      auto t = v->truth();
      if (!t) return S::failure;
      if (!*t) {
        auto e = get_input<NodeStatus>("else");
        return e ? *e : S::failure;
      }
    }
    const S s = child_->execute_tick();
    child_running_ = s == S::running;
    if (is_completed(s)) reset_child();
    return s;
  }
  void halt() override {
    child_running_ = false;
    DecoratorNode::halt();
  }

 private:
  bool child_running_ = false;
};

// UnsetBlackboard: removes the value of entry `key` (a key name); SUCCESS.
class UnsetBlackboard final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {input_port<std::string>("key", "name of the entry to unset")}; }

 protected:
  NodeStatus tick() override {
    auto key = get_input<std::string>("key");
    if (!key) return S::failure;
    blackboard().unset(*key);
    return S::success;
  }
};

// Sequence number seen for the entry of port `entry` ({key}); nullopt when it does not exist.
std::optional<std::uint64_t> entry_sequence(const TreeNode& node) {
  const PortBinding* b = node.port("entry");
  if (b == nullptr || b->source != PortBinding::Source::blackboard) return std::nullopt;
  const Blackboard::Entry* e = node.blackboard().find_entry(b->key);
  if (e == nullptr) return std::nullopt;
  return e->sequence;
}

PortInfo entry_port() {
  return input_port<AnyTypeAllowed>("entry", "blackboard entry to watch, as {key}");
}

// WasEntryUpdated: SUCCESS when the entry was written since this node last looked.
class WasEntryUpdated final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {entry_port()}; }

 protected:
  NodeStatus tick() override {
    const auto seq = entry_sequence(*this);
    if (!seq) return S::failure;
    const bool updated = *seq != seen_;
    seen_ = *seq;
    return updated ? S::success : S::failure;
  }

 private:
  std::uint64_t seen_ = 0;
};

// SkipUnlessUpdated (NotUpdated = SKIPPED) and WaitValueUpdate (NotUpdated = RUNNING): the
// child is ticked only when the entry was written since the last check; once the child is
// RUNNING it keeps being ticked.
template <S NotUpdated>
class EntryUpdatedDecorator final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() { return {entry_port()}; }

 protected:
  NodeStatus tick() override {
    if (!child_running_) {
      const auto seq = entry_sequence(*this);
      if (!seq) return NotUpdated;
      const bool updated = *seq != seen_;
      seen_ = *seq;
      if (!updated) return NotUpdated;
    }
    const S s = child_->execute_tick();
    child_running_ = s == S::running;
    if (is_completed(s)) reset_child();
    return s;
  }
  void halt() override {
    child_running_ = false;
    DecoratorNode::halt();
  }

 private:
  std::uint64_t seen_ = 0;
  bool child_running_ = false;
};

// LoopInt / LoopDouble / LoopString / LoopBool: pops the next element of `queue` into `value`
// and ticks the child; RUNNING after each success (one element per tick), FAILURE when the child
// fails, `if_empty` (default SUCCESS) once the queue is exhausted. The queue is a literal list
// "1;2;3" or an entry holding std::vector<T> (or such a string), copied when the loop starts.
template <typename T>
class LoopNode final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<std::vector<T>>("queue", "elements, as a list a;b;c or {key}"),
            input_port<NodeStatus>("if_empty", "SUCCESS", "status returned when the queue is empty"),
            output_port<T>("value", "the current element")};
  }

 protected:
  NodeStatus tick() override {
    if (status() == S::idle) {
      child_running_ = false;
      auto q = get_input<std::vector<T>>("queue");
      if (!q) return S::failure;
      queue_.assign(q->begin(), q->end());
    }
    bool popped = false;
    if (!child_running_ && !queue_.empty()) {
      const PortBinding* out = port("value");
      if (out != nullptr && out->source == PortBinding::Source::blackboard) (void)set_output("value", queue_.front());
      queue_.pop_front();
      popped = true;
    }
    if (!popped && !child_running_) {
      auto e = get_input<NodeStatus>("if_empty");
      return e ? *e : S::failure;
    }
    set_status(S::running);
    const S s = child_->execute_tick();
    child_running_ = s == S::running;
    if (is_completed(s)) reset_child();
    if (s == S::failure) return S::failure;
    return S::running;
  }
  void halt() override {
    child_running_ = false;
    queue_.clear();
    DecoratorNode::halt();
  }

 private:
  std::deque<T> queue_;
  bool child_running_ = false;
};

}  // namespace

Status register_builtin_script_nodes(NodeRegistry& r) {
  VISNAV_TRY(r.register_node<RunScript>("Script", "Runs a script (e.g. x := 1; y += x); SUCCESS"));
  VISNAV_TRY(r.register_node<ScriptCondition>("ScriptCondition", "SUCCESS when the script evaluates to true"));
  VISNAV_TRY(r.register_node<Precondition>(
      "Precondition", "Ticks the child when the script 'if' is true, else returns 'else'"));
  VISNAV_TRY(r.register_node<UnsetBlackboard>("UnsetBlackboard", "Removes the value of a blackboard entry"));
  VISNAV_TRY(r.register_node<WasEntryUpdated>(
      "WasEntryUpdated", "SUCCESS when the entry was written since the last tick of this node"));
  VISNAV_TRY(r.register_node<EntryUpdatedDecorator<S::skipped>>(
      "SkipUnlessUpdated", "Ticks the child only when the entry was updated, else SKIPPED"));
  VISNAV_TRY(r.register_node<EntryUpdatedDecorator<S::running>>(
      "WaitValueUpdate", "RUNNING until the entry is updated, then ticks the child"));
  VISNAV_TRY(r.register_node<LoopNode<int>>("LoopInt", "Ticks the child once per element of queue (int)"));
  VISNAV_TRY(r.register_node<LoopNode<double>>("LoopDouble", "Ticks the child once per element of queue (double)"));
  VISNAV_TRY(r.register_node<LoopNode<std::string>>("LoopString", "Ticks the child once per element of queue (string)"));
  VISNAV_TRY(r.register_node<LoopNode<bool>>("LoopBool", "Ticks the child once per element of queue (bool)"));
  return ok();
}

}  // namespace visnav::bt::detail
