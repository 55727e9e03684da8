// Built-in decorators (BehaviorTree.CPP v4 semantics). Timed decorators read the tree's Clock.
#include <limits>

#include "builtin_internal.hpp"

namespace visnav::bt::detail {
namespace {

using S = NodeStatus;

// Inverter, ForceSuccess/ForceFailure and KeepRunningUntilFailure tick the child once and only
// translate its completion: SUCCESS -> OnSuccess, FAILURE -> OnFailure (the child is reset);
// RUNNING, SKIPPED and IDLE are passed through.
template <S OnSuccess, S OnFailure>
class MapCompletion final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    const S s = child_->execute_tick();
    if (!is_completed(s)) return s;
    reset_child();
    return s == S::success ? OnSuccess : OnFailure;
  }
};

using Inverter = MapCompletion<S::failure, S::success>;  // SUCCESS <-> FAILURE
template <S Forced>
using ForceStatus = MapCompletion<Forced, Forced>;
// RUNNING while the child succeeds (re-ticking it next tick), FAILURE when it fails.
using KeepRunningUntilFailure = MapCompletion<S::running, S::failure>;

// Repeat and RetryUntilSuccessful share one loop: the child is re-ticked while it completes with
// `Traits::again` (within one tick while it completes synchronously), up to the count in port
// `Traits::port`; the other completed status stops the loop and is returned at once. Reaching
// the count returns `again`. A count of -1 loops forever; then the node returns RUNNING after
// each completed cycle so a synchronous child cannot block the tick thread. SKIPPED/IDLE from
// the child: SKIPPED.
template <typename Traits>
class CountedLoop final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  // A literal count below -1 fails validation (out_of_range) instead of the node's first tick.
  static PortsList provided_ports() {
    return {with_range(input_port<int>(Traits::port, Traits::port_description), -1,
                       static_cast<double>(std::numeric_limits<int>::max()))};
  }

 protected:
  NodeStatus tick() override {
    constexpr S again = Traits::again;
    constexpr S stop = again == S::success ? S::failure : S::success;
    const auto limit = get_input<int>(Traits::port);
    if (!limit || *limit < -1) return S::failure;
    set_status(S::running);
    while (*limit == -1 || count_ < *limit) {
      const S s = child_->execute_tick();
      if (s == again) {
        ++count_;
        reset_child();
        if (*limit == -1) return S::running;
      } else if (s == stop) {
        count_ = 0;
        reset_child();
        return stop;
      } else if (s == S::running) {
        return S::running;
      } else {  // skipped, idle
        reset_child();
        return S::skipped;
      }
    }
    count_ = 0;
    return again;
  }
  void halt() override {
    count_ = 0;
    DecoratorNode::halt();
  }

 private:
  int count_ = 0;  // completed cycles (Repeat) / failed attempts (RetryUntilSuccessful)
};

// Repeat: re-ticks a succeeding child num_cycles times; FAILURE stops the loop.
struct RepeatTraits {
  static constexpr S again = S::success;
  static constexpr const char* port = "num_cycles";
  static constexpr const char* port_description = "repeat a successful child up to N times (-1: forever)";
};
using Repeat = CountedLoop<RepeatTraits>;

// RetryUntilSuccessful: re-ticks a failing child up to num_attempts times; SUCCESS stops.
struct RetryTraits {
  static constexpr S again = S::failure;
  static constexpr const char* port = "num_attempts";
  static constexpr const char* port_description = "attempts before giving up (-1: forever)";
};
using RetryUntilSuccessful = CountedLoop<RetryTraits>;

double msec_to_s(unsigned msec) { return static_cast<double>(msec) * 1e-3; }

// Shared by Timeout and Delay: a timer started at the first tick (`started_`), forgotten when the
// child completes or the node is halted.
class TimedDecorator : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;

 protected:
  /// Ticks the child; when it completes the timer is forgotten and the child reset.
  NodeStatus tick_child() {
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

  bool started_ = false;
};

// Timeout: the child must complete within msec of the first tick, else it is halted and the
// node returns FAILURE. msec <= 0: no limit.
class Timeout final : public TimedDecorator {
 public:
  using TimedDecorator::TimedDecorator;
  static PortsList provided_ports() {
    return {input_port<unsigned>("msec", "time limit in milliseconds, from the first tick")};
  }

 protected:
  NodeStatus tick() override {
    const auto msec = get_input<unsigned>("msec");
    if (!msec) return S::failure;
    if (!started_) {
      started_ = true;
      start_s_ = clock().now_s();
      set_status(S::running);
    }
    if (*msec > 0u && clock().now_s() - start_s_ >= msec_to_s(*msec)) {
      started_ = false;
      halt_child();
      return S::failure;
    }
    return tick_child();
  }

 private:
  double start_s_ = 0.0;
};

// Delay: waits delay_msec from the first tick (RUNNING), then ticks the child.
class Delay final : public TimedDecorator {
 public:
  using TimedDecorator::TimedDecorator;
  static PortsList provided_ports() {
    return {input_port<unsigned>("delay_msec", "delay before ticking the child, in milliseconds")};
  }

 protected:
  NodeStatus tick() override {
    if (!started_) {
      const auto msec = get_input<unsigned>("delay_msec");
      if (!msec) return S::failure;
      started_ = true;
      deadline_s_ = clock().now_s() + msec_to_s(*msec);
      set_status(S::running);
    }
    if (clock().now_s() < deadline_s_) return S::running;
    return tick_child();
  }

 private:
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
