// visnav behaviour trees — actions written as one resumable function (BehaviorTree.CPP's
// CoroActionNode), with C++20 coroutines.
//
//   class Approach : public visnav::bt::CoroActionNode {
//    public:
//     using CoroActionNode::CoroActionNode;
//     static visnav::bt::PortsList provided_ports() { return {visnav::bt::input_port<int>("steps", "3", "")}; }
//
//    protected:
//     visnav::bt::CoroTask run() override {
//       auto steps = get_input<int>("steps");
//       if (!steps) co_return visnav::bt::NodeStatus::failure;
//       for (int i = 0; i < *steps; ++i) {
//         drive_a_bit();
//         co_await yield_running();      // RUNNING for this tick; resumes here on the next one
//       }
//       co_return visnav::bt::NodeStatus::success;
//     }
//     void on_halted() override { stop(); }  // optional
//   };
//
// Semantics (BehaviorTree.CPP v4 CoroActionNode):
//  * a tick while IDLE starts run(); a tick while RUNNING resumes it where it yielded;
//  * `co_await yield_running()` ends the tick with RUNNING;
//  * `co_return status` ends the action with that status (success or failure; running or
//    idle is reported as failure);
//  * halt() while RUNNING destroys the suspended coroutine — the destructors of the locals
//    alive at the yield point run, in reverse order (RAII cleanup), as when a function returns
//    — and then calls on_halted(). The next tick starts run() from the beginning.
// `co_await yield_running()` may appear only in run() itself (a coroutine has no stack of its
// own: helpers called from run() cannot yield). Each start of run() allocates its coroutine
// frame on the heap once; resuming allocates nothing. An exception escaping run() is rethrown
// from tick() (a bug: Tree::tick_once() catches it and halts the tree).
//
// Thread-safety: as every node, ticked and halted from the tick thread only.
#pragma once

#include <coroutine>
#include <exception>
#include <utility>

#include "visnav/bt/node.hpp"

namespace visnav::bt {

/// The return type of CoroActionNode::run(). Move-only; owns the coroutine frame.
class CoroTask {
 public:
  struct promise_type {
    NodeStatus result = NodeStatus::failure;
    std::exception_ptr error;

    CoroTask get_return_object() noexcept { return CoroTask(std::coroutine_handle<promise_type>::from_promise(*this)); }
    std::suspend_always initial_suspend() noexcept { return {}; }  // the first tick resumes it
    std::suspend_always final_suspend() noexcept { return {}; }    // the node reads result, then destroys
    void return_value(NodeStatus s) noexcept { result = s; }
    void unhandled_exception() noexcept { error = std::current_exception(); }
  };

  CoroTask() = default;
  CoroTask(CoroTask&& other) noexcept : handle_(std::exchange(other.handle_, nullptr)) {}
  CoroTask& operator=(CoroTask&& other) noexcept {
    if (this != &other) {
      reset();
      handle_ = std::exchange(other.handle_, nullptr);
    }
    return *this;
  }
  CoroTask(const CoroTask&) = delete;
  CoroTask& operator=(const CoroTask&) = delete;
  ~CoroTask() { reset(); }

  [[nodiscard]] bool valid() const noexcept { return static_cast<bool>(handle_); }
  /// Runs the coroutine to its next yield or its end; returns RUNNING or its final status
  /// (running/idle from co_return become failure). Rethrows an exception that escaped it.
  NodeStatus resume() {
    handle_.resume();
    if (!handle_.done()) return NodeStatus::running;
    promise_type& p = handle_.promise();
    if (p.error) {
      std::exception_ptr e = std::exchange(p.error, nullptr);
      reset();
      std::rethrow_exception(e);
    }
    const NodeStatus s = p.result;
    reset();
    return s == NodeStatus::success || s == NodeStatus::failure ? s : NodeStatus::failure;
  }
  /// Destroys the frame (locals alive at the suspension point are destroyed).
  void reset() noexcept {
    if (handle_) std::exchange(handle_, nullptr).destroy();
  }

 private:
  explicit CoroTask(std::coroutine_handle<promise_type> h) noexcept : handle_(h) {}
  std::coroutine_handle<promise_type> handle_;
};

/// An action written as one coroutine (see the file comment).
class CoroActionNode : public ActionNode {
 public:
  using ActionNode::ActionNode;
  ~CoroActionNode() override = default;  // task_ destroys a frame still suspended

  /// Awaitable that ends the current tick with RUNNING.
  struct YieldRunning {
    [[nodiscard]] bool await_ready() const noexcept { return false; }
    void await_suspend(std::coroutine_handle<>) const noexcept {}
    void await_resume() const noexcept {}
  };
  [[nodiscard]] static YieldRunning yield_running() noexcept { return {}; }

 protected:
  /// The action's body; see the file comment.
  virtual CoroTask run() = 0;
  /// Called after a RUNNING action was halted and its coroutine destroyed.
  virtual void on_halted() {}

  NodeStatus tick() final {
    // A fresh start unless resuming a RUNNING action (an old frame, if any, is destroyed).
    if (status() != NodeStatus::running || !task_.valid()) task_ = run();
    return task_.resume();
  }
  void halt() final {
    task_.reset();
    on_halted();
  }

 private:
  CoroTask task_;
};

}  // namespace visnav::bt
