// Built-in leaves: AlwaysSuccess, AlwaysFailure, SetBlackboard, Sleep; and register_builtin_nodes().
#include "builtin_internal.hpp"

namespace visnav::bt {
namespace detail {
namespace {

using S = NodeStatus;

template <S Result>
class AlwaysStatus final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override { return Result; }
};

// SetBlackboard: writes `value` into the entry named by `output_key`.
//  value: a literal (stored as std::string; readers convert it to their port type) or `{key}`
//         (copies that entry's typed value).
//  output_key: a key name ("goal", "@goal" for the root) or a reference `{goal}`.
class SetBlackboard final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() {
    return {input_port<std::string>("value", "value to write (literal or {key})"),
            inout_port<std::string>("output_key", "blackboard key to write")};
  }

 protected:
  NodeStatus tick() override {
    const PortBinding* value = port("value");
    const PortBinding* key = port("output_key");
    if (value == nullptr || key == nullptr) return S::failure;
    const std::string& target = key->source == PortBinding::Source::blackboard ? key->key : key->text;
    if (target.empty()) return S::failure;
    if (value->source == PortBinding::Source::blackboard) {
      const std::any* src = blackboard().get_any(value->key);
      if (src == nullptr) return S::failure;
      blackboard().set_any(target, *src);
    } else {
      blackboard().set_any(target, std::any(value->text));
    }
    return S::success;
  }
};

// Sleep: RUNNING until msec have passed on the tree's clock since the first tick.
class Sleep final : public StatefulActionNode {
 public:
  using StatefulActionNode::StatefulActionNode;
  static PortsList provided_ports() { return {input_port<int>("msec", "time to wait, in milliseconds")}; }

  NodeStatus on_start() override {
    const auto msec = get_input<int>("msec");
    if (!msec || *msec < 0) return S::failure;
    if (*msec == 0) return S::success;
    deadline_s_ = clock().now_s() + static_cast<double>(*msec) * 1e-3;
    return S::running;
  }
  NodeStatus on_running() override { return clock().now_s() >= deadline_s_ ? S::success : S::running; }
  void on_halted() override {}

 private:
  double deadline_s_ = 0.0;
};

}  // namespace

Status register_builtin_actions(NodeRegistry& r) {
  VISNAV_TRY(r.register_node<AlwaysStatus<S::success>>("AlwaysSuccess", "Returns SUCCESS"));
  VISNAV_TRY(r.register_node<AlwaysStatus<S::failure>>("AlwaysFailure", "Returns FAILURE"));
  VISNAV_TRY(r.register_node<SetBlackboard>("SetBlackboard", "Writes value into the blackboard entry output_key"));
  VISNAV_TRY(r.register_node<Sleep>("Sleep", "Returns RUNNING for msec milliseconds, then SUCCESS"));
  return ok();
}

}  // namespace detail

Status register_builtin_nodes(NodeRegistry& registry) {
  registry.set_registering_builtins(true);
  Status s = detail::register_builtin_controls(registry);
  if (s) s = detail::register_builtin_decorators(registry);
  if (s) s = detail::register_builtin_actions(registry);
  registry.set_registering_builtins(false);
  return s;
}

}  // namespace visnav::bt
