// Built-in control nodes (BehaviorTree.CPP v4 semantics).
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>

#include "builtin_internal.hpp"

namespace visnav::bt::detail {
namespace {

using S = NodeStatus;

// Sequence and Fallback are mirror images: children are ticked in order, a RUNNING child is
// resumed on the next tick (earlier children are not re-ticked), a child returning `Stop` ends
// the node with `Stop` (children reset, restart from the first child next time), and when every
// child has completed otherwise the node returns `Done`.
//   Sequence = <failure, success>: until one fails.   Fallback = <success, failure>: until one succeeds.
// Async (AsyncSequence, AsyncFallback): after a child that was IDLE completes with `Done`
// synchronously and more children remain, the node returns RUNNING (one child per tick), so
// the rest of the tree gets a chance to run and to halt it.
template <NodeStatus Stop, NodeStatus Done, bool Async = false>
class OrderedControl final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    if (status() == S::idle) all_skipped_ = true;
    set_status(S::running);
    const std::size_t n = children_.size();
    while (current_ < n) {
      TreeNode* child = children_[current_];
      [[maybe_unused]] const S before = child->status();
      const S s = child->execute_tick();
      all_skipped_ = all_skipped_ && s == S::skipped;
      if (s == S::running) return S::running;
      if (s == Stop) {
        reset_children();
        current_ = 0;
        return Stop;
      }
      ++current_;  // Done, skipped (or idle)
      if constexpr (Async) {
        if (s == Done && before == S::idle && current_ < n) return S::running;
      }
    }
    reset_children();
    current_ = 0;
    return all_skipped_ ? S::skipped : Done;
  }
  void halt() override {
    current_ = 0;
    ControlNode::halt();
  }

 private:
  std::size_t current_ = 0;
  bool all_skipped_ = true;
};
using Sequence = OrderedControl<S::failure, S::success>;
using Fallback = OrderedControl<S::success, S::failure>;
using AsyncSequence = OrderedControl<S::failure, S::success, true>;
using AsyncFallback = OrderedControl<S::success, S::failure, true>;

// SequenceWithMemory: like Sequence, but after a FAILURE the next tick resumes at the failed
// child (children that already succeeded are not ticked again) until the sequence completes.
class SequenceWithMemory final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    if (status() == S::idle) all_skipped_ = true;
    set_status(S::running);
    const std::size_t n = children_.size();
    while (current_ < n) {
      const S s = children_[current_]->execute_tick();
      all_skipped_ = all_skipped_ && s == S::skipped;
      switch (s) {
        case S::running:
          return S::running;
        case S::failure:
          halt_children(current_);  // keep current_: resume here
          return S::failure;
        case S::success:
        case S::skipped:
        case S::idle:
          ++current_;
          break;
      }
    }
    reset_children();
    current_ = 0;
    return all_skipped_ ? S::skipped : S::success;
  }
  void halt() override {
    current_ = 0;
    ControlNode::halt();
  }

 private:
  std::size_t current_ = 0;
  bool all_skipped_ = true;
};

// ReactiveSequence and ReactiveFallback (mirror images, like OrderedControl): every tick starts
// from the first child. When a child is RUNNING, all other children are halted (a previously
// running later child is interrupted when an earlier one now returns RUNNING); a child returning
// `Stop` halts everything and ends the node with `Stop`; all children completed otherwise → `Done`.
template <NodeStatus Stop, NodeStatus Done>
class ReactiveControl final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    bool all_skipped = true;
    set_status(S::running);
    const std::size_t n = children_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const S s = children_[i]->execute_tick();
      all_skipped = all_skipped && s == S::skipped;
      if (s == S::running) {
        for (std::size_t j = 0; j < n; ++j)
          if (j != i) halt_child(j);
        return S::running;
      }
      if (s == Stop) {
        reset_children();
        return Stop;
      }
      if (s == S::skipped) halt_child(i);
    }
    reset_children();
    return all_skipped ? S::skipped : Done;
  }
};
using ReactiveSequence = ReactiveControl<S::failure, S::success>;
using ReactiveFallback = ReactiveControl<S::success, S::failure>;

// Parallel: ticks every child that has not completed yet. SUCCESS once success_count children
// succeeded, FAILURE once failure_count failed or success became impossible; either way the
// still-running children are halted. Negative counts mean "all children" (-1), "all but one"
// (-2), ...
class Parallel final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList provided_ports() {
    return {input_port<int>("success_count", "-1",
                            "children that must succeed for SUCCESS (-1: all)"),
            input_port<int>("failure_count", "1",
                            "children that must fail for FAILURE (-1: all)")};
  }

 protected:
  NodeStatus tick() override {
    const auto success_param = get_input<int>("success_count");
    const auto failure_param = get_input<int>("failure_count");
    if (!success_param || !failure_param) return finish(S::failure);
    const int n = static_cast<int>(children_.size());
    const int success_threshold = threshold(*success_param, n);
    const int failure_threshold = threshold(*failure_param, n);
    if (success_threshold > n || failure_threshold > n) return finish(S::failure);
    if (status() == S::idle) {
      completed_.assign(children_.size(), 0);
      success_ = failure_ = 0;
    }
    set_status(S::running);
    int skipped = 0;
    for (int i = 0; i < n; ++i) {
      if (completed_[static_cast<std::size_t>(i)] == 0) {
        const S s = children_[static_cast<std::size_t>(i)]->execute_tick();
        switch (s) {
          case S::success:
            completed_[static_cast<std::size_t>(i)] = 1;
            ++success_;
            break;
          case S::failure:
            completed_[static_cast<std::size_t>(i)] = 1;
            ++failure_;
            break;
          case S::skipped:
            ++skipped;
            break;
          case S::running:
          case S::idle:
            break;
        }
      }
      if (success_ >= success_threshold || (*success_param < 0 && success_ + skipped >= success_threshold))
        return finish(S::success);
      if (n - failure_ < success_threshold || failure_ == failure_threshold) return finish(S::failure);
    }
    return skipped == n ? S::skipped : S::running;
  }
  void halt() override {
    clear();
    ControlNode::halt();
  }

 private:
  static int threshold(int param, int n) { return param < 0 ? std::max(n + param + 1, 0) : param; }
  S finish(S s) {
    clear();
    reset_children();
    return s;
  }
  void clear() {
    std::fill(completed_.begin(), completed_.end(), 0);
    success_ = failure_ = 0;
  }

  std::vector<unsigned char> completed_;
  int success_ = 0;
  int failure_ = 0;
};

// ParallelAll: ticks every child that has not completed yet until all have completed (or were
// skipped); then FAILURE when at least max_failures failed, else SUCCESS. max_failures < 0
// means "children + max_failures + 1" (-1: all must fail).
class ParallelAll final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList provided_ports() {
    return {input_port<int>("max_failures", "1", "failed children that make the node fail (-1: all)")};
  }

 protected:
  NodeStatus tick() override {
    const auto param = get_input<int>("max_failures");
    if (!param) return S::failure;
    const int n = static_cast<int>(children_.size());
    const int threshold = *param < 0 ? std::max(n + *param + 1, 0) : *param;
    if (threshold > n) return S::failure;  // could never fail: a configuration error
    if (status() == S::idle) {
      completed_.assign(children_.size(), 0);
      failures_ = 0;
    }
    set_status(S::running);
    int skipped = 0;
    int done = 0;
    for (std::size_t i = 0; i < children_.size(); ++i) {
      if (completed_[i] != 0) {
        ++done;
        continue;
      }
      const S s = children_[i]->execute_tick();
      if (s == S::success || s == S::failure) {
        completed_[i] = 1;
        ++done;
        if (s == S::failure) ++failures_;
      } else if (s == S::skipped) {
        ++skipped;
      }
    }
    if (skipped == n) return S::skipped;
    if (skipped + done >= n) {
      const S out = failures_ >= threshold ? S::failure : S::success;
      reset_children();
      std::fill(completed_.begin(), completed_.end(), 0);
      failures_ = 0;
      return out;
    }
    return S::running;
  }
  void halt() override {
    std::fill(completed_.begin(), completed_.end(), 0);
    failures_ = 0;
    ControlNode::halt();
  }

 private:
  std::vector<unsigned char> completed_;
  int failures_ = 0;
};

// TryCatch: children 0..N-2 are the try block, ticked as a Sequence; the last child is the
// catch block. All try children succeed -> SUCCESS (SKIPPED if all were skipped). One fails ->
// the try block is halted, the catch child is ticked until it completes, then FAILURE whatever
// the catch child returned. catch_on_halt="true": halting the node while the try block runs
// ticks the catch child once (cleanup) before halting.
class TryCatch final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static constexpr int min_children = 2;
  static PortsList provided_ports() {
    return {input_port<bool>("catch_on_halt", "false", "run the catch child once when halted in the try block")};
  }

 protected:
  NodeStatus tick() override {
    if (status() != S::running) {
      skipped_ = 0;
      in_catch_ = false;
      current_ = 0;
    }
    set_status(S::running);
    const std::size_t try_count = children_.size() - 1;
    if (in_catch_) return tick_catch();
    while (current_ < try_count) {
      const S s = children_[current_]->execute_tick();
      if (s == S::running) return S::running;
      if (s == S::failure) {
        halt_children(0);
        in_catch_ = true;
        current_ = 0;
        return tick_catch();
      }
      if (s == S::skipped) ++skipped_;
      ++current_;
    }
    const bool all_skipped = skipped_ == try_count;
    reset_children();
    current_ = 0;
    skipped_ = 0;
    return all_skipped ? S::skipped : S::success;
  }
  void halt() override {
    const auto catch_on_halt = get_input<bool>("catch_on_halt");
    if (catch_on_halt && *catch_on_halt && !in_catch_ && status() == S::running) {
      halt_children(0);
      TreeNode* c = children_.back();
      if (c->execute_tick() == S::running) c->halt_node();
    }
    current_ = 0;
    skipped_ = 0;
    in_catch_ = false;
    ControlNode::halt();
  }

 private:
  S tick_catch() {
    const S c = children_.back()->execute_tick();
    if (c == S::running) return S::running;
    reset_children();
    in_catch_ = false;
    current_ = 0;
    return S::failure;
  }

  std::size_t current_ = 0;
  std::size_t skipped_ = 0;
  bool in_catch_ = false;
};

// IfThenElse: child 0 is the condition; SUCCESS -> tick child 1, FAILURE -> child 2 (or
// FAILURE with only two children). The condition is not re-evaluated while the chosen branch
// is RUNNING.
class IfThenElse final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static constexpr int min_children = 2;
  static constexpr int max_children = 3;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    if (branch_ == 0) {
      const S c = children_[0]->execute_tick();
      if (c == S::running) return S::running;
      if (c == S::success) {
        branch_ = 1;
      } else if (c == S::failure) {
        if (children_.size() == 3) {
          branch_ = 2;
        } else {
          reset_children();
          return S::failure;
        }
      } else {  // skipped condition: nothing to decide
        reset_children();
        return S::skipped;
      }
    }
    const S s = children_[branch_]->execute_tick();
    if (s == S::running) return S::running;
    reset_children();
    branch_ = 0;
    return s;
  }
  void halt() override {
    branch_ = 0;
    ControlNode::halt();
  }

 private:
  std::size_t branch_ = 0;
};

// WhileDoElse: reactive; the condition (child 0) is ticked every tick. SUCCESS -> tick child 1
// (halting child 2), FAILURE -> tick child 2 (halting child 1) or FAILURE with two children.
class WhileDoElse final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static constexpr int min_children = 2;
  static constexpr int max_children = 3;
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    const S c = children_[0]->execute_tick();
    if (c == S::running) return S::running;
    S s = S::failure;
    if (c == S::success) {
      if (children_.size() == 3) halt_child(2);
      s = children_[1]->execute_tick();
    } else if (c == S::failure) {
      halt_child(1);
      if (children_.size() == 3) s = children_[2]->execute_tick();
    } else {
      s = S::skipped;
    }
    if (s == S::running) return S::running;
    reset_children();
    return s;
  }
};

// Equality used by Switch: same text, same registered enum value, or same number.
bool switch_equal(std::string_view a, std::string_view b, const EnumTables* enums) {
  a = detail::trim(a);
  b = detail::trim(b);
  if (a == b) return true;
  auto as_number = [enums](std::string_view t) -> std::optional<double> {
    if (enums != nullptr)
      if (auto e = enums->lookup(t)) return static_cast<double>(*e);
    if (auto d = detail::parse_double(t)) return *d;
    return std::nullopt;
  };
  const auto na = as_number(a);
  const auto nb = as_number(b);
  return na && nb && *na == *nb;
}

// SwitchN: ticks the child whose case_i equals `variable`, else the last (default) child. A
// running child that no longer matches is halted.
template <int N>
class Switch final : public ControlNode {
 public:
  static constexpr int min_children = N + 1;
  static constexpr int max_children = N + 1;

  Switch(const std::string& name, const NodeConfig& config) : ControlNode(name, config) {
    variable_ = port("variable");
    for (int i = 0; i < N; ++i) cases_[static_cast<std::size_t>(i)] = port("case_" + std::to_string(i + 1));
  }
  static PortsList provided_ports() {
    PortsList ports{input_port<std::string>("variable", "value compared with the cases")};
    for (int i = 1; i <= N; ++i) ports.push_back(input_port<std::string>("case_" + std::to_string(i), "case value"));
    return ports;
  }

 protected:
  NodeStatus tick() override {
    int match = N;
    std::string_view variable;
    if (read(variable_, "variable", variable_scratch_, variable)) {
      for (int i = 0; i < N; ++i) {
        std::string_view value;
        if (read(cases_[static_cast<std::size_t>(i)], "case", case_scratch_, value) &&
            switch_equal(variable, value, enums())) {
          match = i;
          break;
        }
      }
    }
    if (running_ >= 0 && running_ != match) halt_child(static_cast<std::size_t>(running_));
    set_status(S::running);
    const S s = children_[static_cast<std::size_t>(match)]->execute_tick();
    if (s == S::skipped) {
      running_ = -1;
    } else if (s == S::running) {
      running_ = match;
    } else {
      reset_children();
      running_ = -1;
    }
    return s;
  }
  void halt() override {
    running_ = -1;
    ControlNode::halt();
  }

 private:
  // Literal ports are read in place (no copy); blackboard ports through get_input.
  bool read(const PortBinding* b, std::string_view, std::string& scratch, std::string_view& out) const {
    if (b == nullptr) return false;
    if (b->source == PortBinding::Source::literal) {
      out = b->text;
      return true;
    }
    auto v = get_input<std::string>(b->name);
    if (!v) return false;
    scratch = std::move(*v);
    out = scratch;
    return true;
  }

  const PortBinding* variable_ = nullptr;
  std::array<const PortBinding*, N> cases_{};
  std::string variable_scratch_;
  std::string case_scratch_;
  int running_ = -1;
};


// ManualSelector: an operator picks which child runs. BehaviorTree.CPP shows a terminal menu,
// which would block the tick thread of a robot; here the choice is the value of `selection`
// (by default the blackboard entry manual_selection), written by whoever drives the robot (a
// node fed by an operator topic, a Script, `--bb`). While no choice is there the node is
// RUNNING (waiting). A choice read from the blackboard is consumed (the entry is unset), so
// each decision is used once; with repeat_last_selection the previous one is reused without
// waiting. A RUNNING child is resumed without a new choice.
class ManualSelector final : public ControlNode {
 public:
  ManualSelector(const std::string& name, const NodeConfig& config) : ControlNode(name, config) {
    selection_ = port("selection");
  }
  static PortsList provided_ports() {
    return {input_port<std::string>("selection", "{manual_selection}",
                                    "the choice: a child's name or 0-based index, or SUCCESS / FAILURE / SKIPPED / "
                                    "RUNNING to return that status; empty or unset = wait (RUNNING)"),
            input_port<bool>("repeat_last_selection", "false", "reuse the previous choice instead of waiting for one")};
  }

 protected:
  NodeStatus tick() override {
    set_status(S::running);
    if (running_ >= 0) return tick_child(static_cast<std::size_t>(running_));
    const auto repeat = get_input<bool>("repeat_last_selection");
    if (!repeat) return S::failure;
    if (!*repeat || !last_) {
      std::optional<Choice> choice = read_choice();
      if (!choice) return S::running;  // waiting for the operator
      last_ = *choice;
    }
    if (last_->child < 0) return last_->status;
    return tick_child(static_cast<std::size_t>(last_->child));
  }
  void halt() override {
    running_ = -1;
    ControlNode::halt();
  }

 private:
  struct Choice {
    int child = -1;                 ///< index, or -1 for a status choice
    NodeStatus status = S::failure;  ///< returned when child < 0 (FAILURE also for a bad choice)
  };

  NodeStatus tick_child(std::size_t i) {
    const S s = children_[i]->execute_tick();
    if (s == S::running) {
      running_ = static_cast<int>(i);
    } else {
      running_ = -1;
      reset_children();
    }
    return s;
  }

  // The operator's choice, nullopt while there is none. Consumed when read from the blackboard.
  std::optional<Choice> read_choice() {
    auto text = get_input<std::string>("selection");
    if (!text) return std::nullopt;  // entry not set yet
    const std::string value(detail::trim(*text));
    if (value.empty()) return std::nullopt;
    if (selection_ != nullptr && selection_->source == PortBinding::Source::blackboard) blackboard().unset(selection_->key);
    for (std::size_t i = 0; i < children_.size(); ++i)
      if (children_[i]->name() == value) return Choice{static_cast<int>(i), S::failure};
    if (value == "SUCCESS") return Choice{-1, S::success};
    if (value == "FAILURE") return Choice{-1, S::failure};
    if (value == "SKIPPED") return Choice{-1, S::skipped};
    if (value == "RUNNING") return Choice{-1, S::running};
    if (auto d = detail::parse_double(value); d && *d >= 0 && *d < static_cast<double>(children_.size()) && *d == std::trunc(*d))
      return Choice{static_cast<int>(*d), S::failure};
    return Choice{-1, S::failure};  // names no child: FAILURE (docs/bt.md)
  }

  const PortBinding* selection_ = nullptr;
  std::optional<Choice> last_;
  int running_ = -1;
};

}  // namespace

Status register_builtin_controls(NodeRegistry& r) {
  VISNAV_TRY(r.register_node<Sequence>("Sequence", "Ticks children in order until one fails; resumes a running child"));
  VISNAV_TRY(r.register_node<SequenceWithMemory>(
      "SequenceWithMemory", "Sequence that does not re-tick children that already succeeded, even after a failure"));
  VISNAV_TRY(r.register_node<ReactiveSequence>(
      "ReactiveSequence", "Sequence that re-ticks all children every tick and halts a running child when an earlier one changes"));
  VISNAV_TRY(r.register_node<Fallback>("Fallback", "Ticks children in order until one succeeds"));
  VISNAV_TRY(r.register_node<AsyncSequence>(
      "AsyncSequence", "Sequence that returns RUNNING after each child that succeeds at once (one child per tick)"));
  VISNAV_TRY(r.register_node<AsyncFallback>(
      "AsyncFallback", "Fallback that returns RUNNING after each child that fails at once (one child per tick)"));
  VISNAV_TRY(r.register_node<ParallelAll>(
      "ParallelAll", "Ticks all children until all complete; fails when at least max_failures failed"));
  VISNAV_TRY(r.register_node<TryCatch>(
      "TryCatch", "Runs children 1..N-1 as a sequence; on a failure runs the last child (catch) and fails"));
  VISNAV_TRY(r.register_node<ReactiveFallback>(
      "ReactiveFallback", "Fallback that re-ticks all children every tick and halts a running child when an earlier one succeeds"));
  VISNAV_TRY(r.register_node<Parallel>("Parallel", "Ticks all children concurrently; succeeds/fails by counts"));
  VISNAV_TRY(r.register_node<IfThenElse>("IfThenElse", "If child 1 succeeds tick child 2, else child 3"));
  VISNAV_TRY(r.register_node<WhileDoElse>(
      "WhileDoElse", "Re-checks child 1 every tick: on success tick child 2, on failure child 3"));
  VISNAV_TRY(r.register_node<ManualSelector>(
      "ManualSelector", "Ticks the child an operator chose through the blackboard (selection); RUNNING while none is chosen"));
  VISNAV_TRY(r.register_node<Switch<2>>("Switch2", "Ticks the child whose case equals variable, else the last child"));
  VISNAV_TRY(r.register_node<Switch<3>>("Switch3", "Ticks the child whose case equals variable, else the last child"));
  VISNAV_TRY(r.register_node<Switch<4>>("Switch4", "Ticks the child whose case equals variable, else the last child"));
  VISNAV_TRY(r.register_node<Switch<5>>("Switch5", "Ticks the child whose case equals variable, else the last child"));
  VISNAV_TRY(r.register_node<Switch<6>>("Switch6", "Ticks the child whose case equals variable, else the last child"));
  return ok();
}

}  // namespace visnav::bt::detail
