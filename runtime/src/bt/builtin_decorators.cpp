// Built-in decorators (BehaviorTree.CPP v4 semantics). Timed decorators read the tree's Clock.
#include "builtin_internal.hpp"

namespace visnav::bt::detail {
namespace {

using S = NodeStatus;

class Inverter final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    const S s = child_->execute_tick();
    switch (s) {
      case S::success:
        reset_child();
        return S::failure;
      case S::failure:
        reset_child();
        return S::success;
      case S::running:
      case S::skipped:
      case S::idle:
        break;
    }
    return s;
  }
};

template <S Forced>
class ForceStatus final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    const S s = child_->execute_tick();
    if (is_completed(s)) {
      reset_child();
      return Forced;
    }
    return s;
  }
};

// Repeat: re-ticks a succeeding child num_cycles times (within one tick while the child
// completes synchronously); FAILURE stops the loop. num_cycles = -1 repeats forever; in that
// case the node returns RUNNING after each completed cycle so a synchronous child cannot
// block the tick thread.
class Repeat final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<int>("num_cycles", "repeat a successful child up to N times (-1: forever)")};
  }

 protected:
  NodeStatus tick() override {
    const auto cycles = get_input<int>("num_cycles");
    if (!cycles || *cycles < -1) return S::failure;
    set_status(S::running);
    while (*cycles == -1 || count_ < *cycles) {
      const S s = child_->execute_tick();
      switch (s) {
        case S::success:
          ++count_;
          reset_child();
          if (*cycles == -1) return S::running;
          break;
        case S::failure:
          count_ = 0;
          reset_child();
          return S::failure;
        case S::running:
          return S::running;
        case S::skipped:
        case S::idle:
          reset_child();
          return S::skipped;
      }
    }
    count_ = 0;
    return S::success;
  }
  void halt() override {
    count_ = 0;
    DecoratorNode::halt();
  }

 private:
  int count_ = 0;
};

// RetryUntilSuccessful: re-ticks a failing child up to num_attempts times; SUCCESS stops.
// num_attempts = -1 retries forever (returning RUNNING after each failed attempt).
class RetryUntilSuccessful final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<int>("num_attempts", "attempts before giving up (-1: forever)")};
  }

 protected:
  NodeStatus tick() override {
    const auto attempts = get_input<int>("num_attempts");
    if (!attempts || *attempts < -1) return S::failure;
    set_status(S::running);
    while (*attempts == -1 || tries_ < *attempts) {
      const S s = child_->execute_tick();
      switch (s) {
        case S::success:
          tries_ = 0;
          reset_child();
          return S::success;
        case S::failure:
          ++tries_;
          reset_child();
          if (*attempts == -1) return S::running;
          break;
        case S::running:
          return S::running;
        case S::skipped:
        case S::idle:
          reset_child();
          return S::skipped;
      }
    }
    tries_ = 0;
    return S::failure;
  }
  void halt() override {
    tries_ = 0;
    DecoratorNode::halt();
  }

 private:
  int tries_ = 0;
};

double msec_to_s(int msec) { return static_cast<double>(msec) * 1e-3; }

// Timeout: the child must complete within msec of the first tick, else it is halted and the
// node returns FAILURE. msec <= 0: no limit.
class Timeout final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<int>("msec", "time limit in milliseconds, from the first tick")};
  }

 protected:
  NodeStatus tick() override {
    const auto msec = get_input<int>("msec");
    if (!msec) return S::failure;
    if (!started_) {
      started_ = true;
      start_s_ = clock().now_s();
      set_status(S::running);
    }
    if (*msec > 0 && clock().now_s() - start_s_ >= msec_to_s(*msec)) {
      started_ = false;
      halt_child();
      return S::failure;
    }
    const S s = child_->execute_tick();
    if (is_completed(s)) {
      started_ = false;
      reset_child();
    }
    return s;
  }
  void halt() override {
    started_ = false;
    DecoratorNode::halt();
  }

 private:
  bool started_ = false;
  double start_s_ = 0.0;
};

// Delay: waits delay_msec from the first tick (RUNNING), then ticks the child.
class Delay final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<int>("delay_msec", "delay before ticking the child, in milliseconds")};
  }

 protected:
  NodeStatus tick() override {
    if (!started_) {
      const auto msec = get_input<int>("delay_msec");
      if (!msec || *msec < 0) return S::failure;
      started_ = true;
      deadline_s_ = clock().now_s() + msec_to_s(*msec);
      set_status(S::running);
    }
    if (clock().now_s() < deadline_s_) return S::running;
    const S s = child_->execute_tick();
    if (is_completed(s)) {
      started_ = false;
      reset_child();
    }
    return s;
  }
  void halt() override {
    started_ = false;
    DecoratorNode::halt();
  }

 private:
  bool started_ = false;
  double deadline_s_ = 0.0;
};

// RunOnce: ticks the child until it completes once; afterwards returns SKIPPED (then_skip,
// default) or the child's final status, without ticking it again.
class RunOnce final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() {
    return {input_port<bool>("then_skip", "true", "after the first completion: true = SKIPPED, false = repeat the status")};
  }

 protected:
  NodeStatus tick() override {
    if (done_) {
      const auto skip = get_input<bool>("then_skip");
      return (!skip || *skip) ? S::skipped : result_;
    }
    set_status(S::running);
    const S s = child_->execute_tick();
    if (is_completed(s)) {
      done_ = true;
      result_ = s;
      reset_child();
    }
    return s;
  }

 private:
  bool done_ = false;
  S result_ = S::idle;
};

// KeepRunningUntilFailure: RUNNING while the child succeeds (re-ticking it), FAILURE when it fails.
class KeepRunningUntilFailure final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    const S s = child_->execute_tick();
    switch (s) {
      case S::failure:
        reset_child();
        return S::failure;
      case S::success:
        reset_child();
        return S::running;
      case S::running:
      case S::skipped:
      case S::idle:
        break;
    }
    return s;
  }
};

}  // namespace

Status register_builtin_decorators(NodeRegistry& r) {
  VISNAV_TRY(r.register_node<Inverter>("Inverter", "SUCCESS <-> FAILURE"));
  VISNAV_TRY(r.register_node<ForceStatus<S::success>>("ForceSuccess", "SUCCESS whenever the child completes"));
  VISNAV_TRY(r.register_node<ForceStatus<S::failure>>("ForceFailure", "FAILURE whenever the child completes"));
  VISNAV_TRY(r.register_node<Repeat>("Repeat", "Repeats a succeeding child num_cycles times"));
  VISNAV_TRY(r.register_node<RetryUntilSuccessful>("RetryUntilSuccessful", "Retries a failing child num_attempts times"));
  VISNAV_TRY(r.register_node<Timeout>("Timeout", "Halts the child and fails after msec"));
  VISNAV_TRY(r.register_node<Delay>("Delay", "Ticks the child after delay_msec"));
  VISNAV_TRY(r.register_node<RunOnce>("RunOnce", "Executes the child only once"));
  VISNAV_TRY(r.register_node<KeepRunningUntilFailure>("KeepRunningUntilFailure",
                                                      "RUNNING while the child succeeds, FAILURE when it fails"));
  return ok();
}

}  // namespace visnav::bt::detail
