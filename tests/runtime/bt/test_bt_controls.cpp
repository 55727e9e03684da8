// Control nodes: tick order, memory, reactivity and halting (BehaviorTree.CPP v4 semantics).
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::NodeStatus;
constexpr NodeStatus kIdle = NodeStatus::idle;
constexpr NodeStatus kRunning = NodeStatus::running;
constexpr NodeStatus kSuccess = NodeStatus::success;
constexpr NodeStatus kFailure = NodeStatus::failure;

using Controls = BtTest;

// ---- Sequence ------------------------------------------------------------------------------

TEST_F(Controls, SequenceTicksChildrenInOrderAndSucceeds) {
  auto tree = load_main(R"(<Sequence><Act name="A"/><Act name="B"/><Act name="C"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B C");
  // Children are reset to IDLE when the sequence completes.
  tree.visit([&](visnav::bt::TreeNode& n) {
    if (&n != &tree.root()) {
      EXPECT_EQ(n.status(), kIdle) << n.path();
    }
  });
}

TEST_F(Controls, SequenceStopsAtFirstFailure) {
  world.set("B", kFailure);
  auto tree = load_main(R"(<Sequence><Act name="A"/><Act name="B"/><Act name="C"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A B");
}

TEST_F(Controls, SequenceResumesRunningChildWithoutReTickingEarlierOnes) {
  world.push("B", {kRunning, kSuccess});
  auto tree = load_main(R"(<Sequence><Act name="A"/><Async name="B"/><Act name="C"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A B:start");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B:run C");
}

TEST_F(Controls, SequenceRestartsFromFirstChildAfterFailure) {
  world.push("B", {kFailure, kSuccess});
  auto tree = load_main(R"(<Sequence><Act name="A"/><Act name="B"/><Act name="C"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A B");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B C");
}

TEST_F(Controls, SequenceHaltHaltsRunningChild) {
  auto tree = load_main(R"(<Sequence><Act name="A"/><Async name="B"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  world.take();
  tree.halt();
  EXPECT_EQ(world.take(), "B:halt");
  EXPECT_EQ(tree.status(), kIdle);
  EXPECT_EQ(tree.find_node("MainTree/Sequence[0]/B")->status(), kIdle);
  // After a halt the sequence starts again from its first child.
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A B:start");
}

// ---- SequenceWithMemory ----------------------------------------------------------------------

TEST_F(Controls, SequenceWithMemoryDoesNotReTickSucceededChildrenAfterFailure) {
  world.push("B", {kFailure, kSuccess});
  auto tree = load_main(R"(<SequenceWithMemory><Act name="A"/><Act name="B"/><Act name="C"/></SequenceWithMemory>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A B");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B C");
  // Completed: the next run starts from the first child again.
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B C");
}

TEST_F(Controls, SequenceWithMemoryResumesRunningChild) {
  world.push("B", {kRunning, kRunning, kSuccess});
  auto tree = load_main(R"(<SequenceWithMemory><Act name="A"/><Async name="B"/></SequenceWithMemory>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B:start B:run B:run");
}

TEST_F(Controls, SequenceWithMemoryHaltResetsMemory) {
  world.push("B", {kFailure});
  auto tree = load_main(
      R"(<ReactiveSequence><Cond name="Gate"/><SequenceWithMemory><Act name="A"/><Act name="B"/><Async name="C"/></SequenceWithMemory></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "Gate A B");
  EXPECT_EQ(tree.tick_once(), kRunning);  // memory: resumes at B
  EXPECT_EQ(world.take(), "Gate B C:start");
  tree.halt();
  EXPECT_EQ(world.take(), "C:halt");
  EXPECT_EQ(tree.tick_once(), kRunning);  // halted while running: memory cleared
  EXPECT_EQ(world.take(), "Gate A B C:start");
}

// ---- ReactiveSequence ------------------------------------------------------------------------

TEST_F(Controls, ReactiveSequenceReTicksConditionsEveryTick) {
  auto tree = load_main(R"(<ReactiveSequence><Cond name="C"/><Async name="R"/></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "C R:start C R:run");
}

TEST_F(Controls, ReactiveSequenceHaltsRunningChildWhenConditionFails) {
  world.push("C", {kSuccess, kFailure});
  auto tree = load_main(R"(<ReactiveSequence><Cond name="C"/><Async name="R"/></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "C R:start");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "C R:halt");
  EXPECT_EQ(tree.find_node("MainTree/ReactiveSequence[0]/R")->status(), kIdle);
}

TEST_F(Controls, ReactiveSequenceHaltsLaterRunningChildWhenEarlierOneRuns) {
  world.push("A", {kSuccess, kRunning});
  auto tree = load_main(R"(<ReactiveSequence><Async name="A"/><Async name="B"/></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:start B:start");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:start B:halt");
}

TEST_F(Controls, ReactiveSequenceSucceedsWhenAllSucceed) {
  world.push("R", {kRunning, kSuccess});
  auto tree = load_main(R"(<ReactiveSequence><Cond name="C"/><Async name="R"/></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C R:start C R:run");
}

// ---- Fallback ----------------------------------------------------------------------------------

TEST_F(Controls, FallbackReturnsFirstSuccess) {
  world.set("A", kFailure);
  auto tree = load_main(R"(<Fallback><Act name="A"/><Act name="B"/><Act name="C"/></Fallback>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B");
}

TEST_F(Controls, FallbackFailsWhenAllFail) {
  world.set("A", kFailure);
  world.set("B", kFailure);
  auto tree = load_main(R"(<Fallback><Act name="A"/><Act name="B"/></Fallback>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A B");
}

TEST_F(Controls, FallbackResumesRunningChildWithoutReTickingEarlierOnes) {
  world.set("C", kFailure);
  auto tree = load_main(R"(<Fallback><Cond name="C"/><Async name="R"/></Fallback>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "C R:start R:run");
}

// ---- ReactiveFallback --------------------------------------------------------------------------

TEST_F(Controls, ReactiveFallbackHaltsRunningChildWhenEarlierChildSucceeds) {
  world.push("C", {kFailure, kFailure, kSuccess});
  auto tree = load_main(R"(<ReactiveFallback><Cond name="C"/><Async name="R"/></ReactiveFallback>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "C R:start C R:run");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C R:halt");
}

TEST_F(Controls, ReactiveFallbackFailsWhenAllFail) {
  world.set("C", kFailure);
  world.set("D", kFailure);
  auto tree = load_main(R"(<ReactiveFallback><Cond name="C"/><Act name="D"/></ReactiveFallback>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "C D");
}

// ---- Parallel ----------------------------------------------------------------------------------

TEST_F(Controls, ParallelDefaultNeedsAllChildrenAndDoesNotReTickCompletedOnes) {
  world.push("A", {kRunning, kSuccess});
  world.push("B", {kRunning, kRunning, kSuccess});
  auto tree = load_main(R"(<Parallel><Async name="A"/><Async name="B"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:start B:start");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:run B:run");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B:run");
}

TEST_F(Controls, ParallelSuccessCountHaltsRemainingRunningChildren) {
  world.push("A", {kRunning, kSuccess});
  auto tree = load_main(R"(<Parallel success_count="1"><Async name="A"/><Async name="B"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:start B:start");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A:run B:halt");
  EXPECT_EQ(tree.find_node("MainTree/Parallel[0]/B")->status(), kIdle);
}

TEST_F(Controls, ParallelFailsOnFirstFailureByDefaultAndHaltsOthers) {
  world.push("B", {kFailure});
  auto tree = load_main(R"(<Parallel><Async name="A"/><Async name="B"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A:start B:start A:halt");
}

TEST_F(Controls, ParallelFailureCountTwo) {
  world.set("A", kFailure);
  world.set("B", kFailure);
  auto tree = load_main(
      R"(<Parallel success_count="1" failure_count="2"><Act name="A"/><Act name="B"/><Act name="C"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A B");
}

TEST_F(Controls, ParallelFailsWhenSuccessBecomesImpossible) {
  world.set("A", kFailure);
  auto tree = load_main(
      R"(<Parallel success_count="2" failure_count="-1"><Act name="A"/><Async name="B"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A");
}

TEST_F(Controls, ParallelThresholdLargerThanChildrenFails) {
  auto tree = load_main(R"(<Parallel success_count="3"><Act name="A"/><Act name="B"/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "");
}

// ---- IfThenElse / WhileDoElse ------------------------------------------------------------------

TEST_F(Controls, IfThenElseTakesThenBranchOnSuccess) {
  world.set("T", kFailure);
  auto tree = load_main(R"(<IfThenElse><Cond name="C"/><Act name="T"/><Act name="E"/></IfThenElse>)");
  EXPECT_EQ(tree.tick_once(), kFailure);  // the branch's result
  EXPECT_EQ(world.take(), "C T");
}

TEST_F(Controls, IfThenElseTakesElseBranchOnFailure) {
  world.set("C", kFailure);
  auto tree = load_main(R"(<IfThenElse><Cond name="C"/><Act name="T"/><Act name="E"/></IfThenElse>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C E");
}

TEST_F(Controls, IfThenElseWithTwoChildrenFailsWhenConditionFails) {
  world.set("C", kFailure);
  auto tree = load_main(R"(<IfThenElse><Cond name="C"/><Act name="T"/></IfThenElse>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "C");
}

TEST_F(Controls, IfThenElseDoesNotReEvaluateConditionWhileBranchRuns) {
  world.push("C", {kSuccess, kFailure});
  world.push("T", {kRunning, kRunning, kSuccess});
  auto tree = load_main(R"(<IfThenElse><Cond name="C"/><Async name="T"/><Act name="E"/></IfThenElse>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C T:start T:run T:run");
}

TEST_F(Controls, WhileDoElseReEvaluatesConditionAndHaltsDoBranch) {
  world.push("C", {kSuccess, kSuccess, kFailure});
  auto tree = load_main(R"(<WhileDoElse><Cond name="C"/><Async name="D"/><Act name="E"/></WhileDoElse>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "C D:start C D:run");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C D:halt E");
}

TEST_F(Controls, WhileDoElseHaltsElseBranchWhenConditionSucceeds) {
  world.push("C", {kFailure, kSuccess});
  auto tree = load_main(R"(<WhileDoElse><Cond name="C"/><Act name="D"/><Async name="E"/></WhileDoElse>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C E:start C E:halt D");
}

// ---- Switch ------------------------------------------------------------------------------------

TEST_F(Controls, Switch2TicksMatchingCase) {
  auto tree = load_main(
      R"(<Switch2 variable="{dir}" case_1="left" case_2="right"><Act name="L"/><Act name="R"/><Act name="D"/></Switch2>)");
  tree.blackboard().set("dir", std::string("right"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  tree.blackboard().set("dir", std::string("left"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "R L");
}

TEST_F(Controls, SwitchFallsBackToDefaultChild) {
  auto tree = load_main(
      R"(<Switch3 variable="{dir}" case_1="a" case_2="b" case_3="c"><Act name="A"/><Act name="B"/><Act name="C"/><Act name="D"/></Switch3>)");
  tree.blackboard().set("dir", std::string("zzz"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "D");
  // A missing variable also selects the default.
  auto tree2 = load_main(
      R"(<Switch2 variable="{nothing}" case_1="a" case_2="b"><Act name="A"/><Act name="B"/><Act name="D"/></Switch2>)");
  EXPECT_EQ(tree2.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "D");
}

TEST_F(Controls, SwitchComparesNumbersAndEnumNames) {
  auto tree = load_main(
      R"(<Switch4 variable="{v}" case_1="1" case_2="2.0" case_3="blue" case_4="x"><Act name="A"/><Act name="B"/><Act name="C"/><Act name="X"/><Act name="D"/></Switch4>)");
  tree.blackboard().set("v", 2);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  tree.blackboard().set("v", 7);  // Color::blue
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B C");
}

TEST_F(Controls, SwitchHaltsRunningChildWhenVariableChanges) {
  auto tree = load_main(
      R"(<Switch2 variable="{dir}" case_1="left" case_2="right"><Async name="L"/><Async name="R"/><Act name="D"/></Switch2>)");
  tree.blackboard().set("dir", std::string("left"));
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.blackboard().set("dir", std::string("right"));
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "L:start L:halt R:start");
}

TEST_F(Controls, Switch6HasSixCasesAndDefault) {
  auto tree = load_main(
      R"(<Switch6 variable="6" case_1="1" case_2="2" case_3="3" case_4="4" case_5="5" case_6="6"><Act name="A"/><Act name="B"/><Act name="C"/><Act name="D"/><Act name="E"/><Act name="F"/><Act name="G"/></Switch6>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "F");
}

TEST_F(Controls, SequenceOfSkippedChildrenIsSkipped) {
  auto tree = load_main(R"(<Sequence><RunOnce><Act name="A"/></RunOnce></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(tree.tick_once(), NodeStatus::skipped);
  EXPECT_EQ(world.take(), "A");
}

}  // namespace
}  // namespace bt_test
