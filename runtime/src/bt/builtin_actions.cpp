// Built-in leaves: AlwaysSuccess, AlwaysFailure, SetBlackboard, Sleep; and register_builtin_nodes().
#include "builtin_internal.hpp"
#include "visnav/bt/script.hpp"

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

// SetBlackboard: writes `value` into the entry named by `output_key` (BehaviorTree.CPP v4):
//  value: a literal (text) or `{key}` (copies that entry's value);
//  output_key: a key name ("goal", "@goal" for the root), or `{k}`: the key named by the
//         string held in entry k.
// When the destination entry has a declared type (typed blackboard), a text value is parsed
// as that type and numbers are converted when exact; a value that does not convert fails the
// node (the message goes to the tree's last_script_error()).
class SetBlackboard final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() {
    return {input_port<AnyTypeAllowed>("value", "value to write (literal or {key})"),
            inout_port<AnyTypeAllowed>("output_key", "name of the entry to write (or {k}: the name held in k)")};
  }

 protected:
  NodeStatus tick() override {
    const PortBinding* value = port("value");
    const PortBinding* key = port("output_key");
    if (value == nullptr || key == nullptr) return S::failure;
    std::string target;
    if (key->source == PortBinding::Source::blackboard) {
      auto name = blackboard().get<std::string>(key->key);
      if (!name) return error(name.error().message);
      target = std::move(*name);
    } else {
      target = key->text;
    }
    if (target.empty()) return error("output_key names no entry");
    std::any out;
    if (value->source == PortBinding::Source::blackboard) {
      const std::any* src = blackboard().get_any(value->key);
      if (src == nullptr) return error("blackboard key '" + value->key + "' is not set");
      out = *src;
    } else {
      out = std::any(value->text);
    }
    Blackboard::Entry& dst = blackboard().get_or_create_entry(target);
    auto converted = convert_for_entry(out, dst, enums());
    if (!converted) return error("entry '" + target + "': " + converted.error().message);
    dst.value = std::move(*converted);
    ++dst.sequence;
    return S::success;
  }

 private:
  NodeStatus error(const std::string& message) {
    if (config().context != nullptr) config().context->last_script_error = where().str() + ": " + path() + ": " + message;
    return S::failure;
  }
};

// Sleep: RUNNING until msec have passed on the tree's clock since the first tick.
class Sleep final : public StatefulActionNode {
 public:
  using StatefulActionNode::StatefulActionNode;
  static PortsList provided_ports() { return {input_port<unsigned>("msec", "time to wait, in milliseconds")}; }

  NodeStatus on_start() override {
    const auto msec = get_input<unsigned>("msec");
    if (!msec) return S::failure;
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
  if (s) s = detail::register_builtin_script_nodes(registry);
  registry.set_registering_builtins(false);
  return s;
}

}  // namespace visnav::bt
