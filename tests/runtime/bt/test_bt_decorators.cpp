// Decorators and built-in leaves.
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::NodeStatus;
constexpr NodeStatus kIdle = NodeStatus::idle;
constexpr NodeStatus kRunning = NodeStatus::running;
constexpr NodeStatus kSuccess = NodeStatus::success;
constexpr NodeStatus kFailure = NodeStatus::failure;

using Decorators = BtTest;
using Leaves = BtTest;

TEST_F(Decorators, InverterSwapsSuccessAndFailure) {
  world.push("A", {kSuccess, kFailure});
  auto tree = load_main(R"(<Inverter><Act name="A"/></Inverter>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(tree.tick_once(), kSuccess);
}

TEST_F(Decorators, InverterPassesRunningThrough) {
  auto tree = load_main(R"(<Inverter><Async name="A"/></Inverter>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.halt();
  EXPECT_EQ(world.take(), "A:start A:halt");
}

TEST_F(Decorators, ForceSuccessAndForceFailure) {
  world.set("A", kFailure);
  auto t1 = load_main(R"(<ForceSuccess><Act name="A"/></ForceSuccess>)");
  EXPECT_EQ(t1.tick_once(), kSuccess);
  auto t2 = load_main(R"(<ForceFailure><Act name="B"/></ForceFailure>)");
  EXPECT_EQ(t2.tick_once(), kFailure);
  auto t3 = load_main(R"(<ForceFailure><Async name="C"/></ForceFailure>)");
  EXPECT_EQ(t3.tick_once(), kRunning);
}

TEST_F(Decorators, RepeatTicksSynchronousChildNumCyclesTimesInOneTick) {
  auto tree = load_main(R"(<Repeat num_cycles="3"><Act name="A"/></Repeat>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A A A");
  EXPECT_EQ(tree.tick_once(), kSuccess);  // counter reset after completion
  EXPECT_EQ(world.take(), "A A A");
}

TEST_F(Decorators, RepeatStopsOnFailure) {
  world.push("A", {kSuccess, kFailure});
  auto tree = load_main(R"(<Repeat num_cycles="5"><Act name="A"/></Repeat>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A A");
}

TEST_F(Decorators, RepeatWithAsynchronousChild) {
  world.push("A", {kRunning, kSuccess, kRunning, kSuccess});
  auto tree = load_main(R"(<Repeat num_cycles="2"><Async name="A"/></Repeat>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A:start A:run A:start A:run");
}

TEST_F(Decorators, RepeatForeverYieldsAfterEachCycle) {
  auto tree = load_main(R"(<Repeat num_cycles="-1"><Act name="A"/></Repeat>)");
  for (int i = 0; i < 3; ++i) EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A A A");
}

TEST_F(Decorators, RepeatNumCyclesFromBlackboard) {
  auto tree = load_main(R"(<Repeat num_cycles="{n}"><Act name="A"/></Repeat>)");
  tree.blackboard().set("n", 2);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A A");
}

TEST_F(Decorators, RetryUntilSuccessfulRetriesFailingChild) {
  world.push("A", {kFailure, kFailure, kSuccess});
  auto tree = load_main(R"(<RetryUntilSuccessful num_attempts="3"><Act name="A"/></RetryUntilSuccessful>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A A A");
}

TEST_F(Decorators, RetryUntilSuccessfulGivesUpAfterNumAttempts) {
  world.set("A", kFailure);
  auto tree = load_main(R"(<RetryUntilSuccessful num_attempts="2"><Act name="A"/></RetryUntilSuccessful>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A A");
}

TEST_F(Decorators, RetryForeverYieldsAfterEachFailure) {
  world.push("A", {kFailure, kFailure, kSuccess});
  auto tree = load_main(R"(<RetryUntilSuccessful num_attempts="-1"><Act name="A"/></RetryUntilSuccessful>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kSuccess);
}

TEST_F(Decorators, RetryHaltedWhileChildRunsResetsAttempts) {
  world.push("A", {kFailure, kRunning});
  auto tree = load_main(R"(<RetryUntilSuccessful num_attempts="2"><Async name="A"/></RetryUntilSuccessful>)");
  EXPECT_EQ(tree.tick_once(), kRunning);  // attempt 1 failed, attempt 2 running
  tree.halt();
  EXPECT_EQ(world.take(), "A:start A:start A:halt");
  world.push("A", {kFailure, kFailure});
  EXPECT_EQ(tree.tick_once(), kFailure);  // two fresh attempts
  EXPECT_EQ(world.take(), "A:start A:start");
}

TEST_F(Decorators, TimeoutHaltsChildAndFails) {
  auto tree = load_main(R"(<Timeout msec="100"><Async name="A"/></Timeout>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(50);
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(60);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A:start A:run A:halt");
  EXPECT_EQ(tree.find_node("MainTree/Timeout[0]/A")->status(), kIdle);
}

TEST_F(Decorators, TimeoutPassesResultWhenChildFinishesInTimeAndRestartsTimer) {
  world.push("A", {kRunning, kSuccess});
  auto tree = load_main(R"(<Timeout msec="100"><Async name="A"/></Timeout>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(90);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  clock.advance_ms(500);
  EXPECT_EQ(tree.tick_once(), kRunning);  // new run, new timer
  clock.advance_ms(99);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "A:start A:run A:start A:run");
}

TEST_F(Decorators, DelayWaitsBeforeTickingChild) {
  auto tree = load_main(R"(<Delay delay_msec="100"><Act name="A"/></Delay>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(99);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "");
  clock.advance_ms(2);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A");
}

TEST_F(Decorators, DelayRestartsAfterHalt) {
  auto tree = load_main(R"(<Delay delay_msec="100"><Act name="A"/></Delay>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(80);
  tree.halt();
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(80);
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(30);
  EXPECT_EQ(tree.tick_once(), kSuccess);
}

TEST_F(Decorators, RunOnceSkipsAfterFirstCompletion) {
  auto tree = load_main(R"(<Sequence><RunOnce><Act name="A"/></RunOnce><Act name="B"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A B B");
}

TEST_F(Decorators, RunOnceSkippedChildIsIgnoredByFallback) {
  auto tree = load_main(R"(<Fallback><RunOnce><Act name="A"/></RunOnce><Act name="B"/></Fallback>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B");
}

TEST_F(Decorators, RunOnceWithoutSkipRepeatsTheResult) {
  world.set("A", kFailure);
  auto tree = load_main(R"(<RunOnce then_skip="false"><Act name="A"/></RunOnce>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A");
}

TEST_F(Decorators, KeepRunningUntilFailure) {
  world.push("A", {kSuccess, kSuccess, kFailure});
  auto tree = load_main(R"(<KeepRunningUntilFailure><Act name="A"/></KeepRunningUntilFailure>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "A A A");
}

TEST_F(Decorators, DecoratorHaltPropagatesToNestedRunningChild) {
  auto tree = load_main(
      R"(<Inverter><ForceSuccess><Timeout msec="1000"><Sequence><Act name="A"/><Async name="B"/></Sequence></Timeout></ForceSuccess></Inverter>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.halt();
  EXPECT_EQ(world.take(), "A B:start B:halt");
  tree.visit([](visnav::bt::TreeNode& n) { EXPECT_EQ(n.status(), kIdle) << n.path(); });
}

// ---- leaves ------------------------------------------------------------------------------------

TEST_F(Leaves, AlwaysSuccessAndAlwaysFailure) {
  auto t1 = load_main(R"(<AlwaysSuccess/>)");
  EXPECT_EQ(t1.tick_once(), kSuccess);
  auto t2 = load_main(R"(<AlwaysFailure/>)");
  EXPECT_EQ(t2.tick_once(), kFailure);
}

TEST_F(Leaves, SetBlackboardConvertsToTheDeclaredTypeOfTheEntry) {
  auto tree = load_main(R"(<Sequence>
    <SetBlackboard value="21" output_key="n"/>
    <SetBlackboard value="2.5" output_key="x"/>
    <SetBlackboard value="free text" output_key="untyped"/>
    <Probe i="{n}" d="{x}" out_i="{doubled}" out_s="{s}"/>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(*tree.blackboard().get<int>("doubled"), 42);
  // n and x were declared int and double by Probe's ports: the text was converted (BT.CPP).
  EXPECT_EQ(tree.blackboard().get_any("n")->type(), typeid(int));
  EXPECT_EQ(tree.blackboard().get_any("x")->type(), typeid(double));
  EXPECT_EQ(tree.blackboard().get_any("untyped")->type(), typeid(std::string));
  EXPECT_EQ(*tree.blackboard().get<std::string>("n"), "21");
}

TEST_F(Leaves, SetBlackboardFailsWhenTextDoesNotConvertToTheDeclaredType) {
  auto tree = load_main(R"(<Sequence>
    <SetBlackboard value="many" output_key="n"/>
    <Probe i="{n}" d="1" out_i="{o}" out_s="{s}"/>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_NE(tree.last_script_error().find("cannot convert 'many' to int"), std::string::npos) << tree.last_script_error();
}

TEST_F(Leaves, SetBlackboardOutputKeyInBracesNamesTheKeyHeldInThatEntry) {
  // BT.CPP reads output_key as a port: {k} is the name stored in k, not k itself.
  auto tree = load_main(R"(<Sequence>
    <SetBlackboard value="target" output_key="k"/>
    <SetBlackboard value="hello" output_key="{k}"/>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(*tree.blackboard().get<std::string>("target"), "hello");
  EXPECT_EQ(*tree.blackboard().get<std::string>("k"), "target");
}

TEST_F(Leaves, SetBlackboardCopiesTypedEntry) {
  auto tree = load_main(R"(<SetBlackboard value="{src}" output_key="dst"/>)");
  tree.blackboard().set("src", 3.25);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  const std::any* v = tree.blackboard().get_any("dst");
  ASSERT_NE(v, nullptr);
  ASSERT_EQ(v->type(), typeid(double));
  EXPECT_DOUBLE_EQ(std::any_cast<double>(*v), 3.25);
}

TEST_F(Leaves, SetBlackboardFailsWhenSourceKeyMissing) {
  auto tree = load_main(R"(<SetBlackboard value="{nothing}" output_key="dst"/>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_FALSE(tree.blackboard().has("dst"));
}

TEST_F(Leaves, SleepRunsForMsecOnTheTreeClock) {
  auto tree = load_main(R"(<Sleep msec="200"/>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(199);
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(1);
  EXPECT_EQ(tree.tick_once(), kSuccess);
}

TEST_F(Leaves, SleepCanBeHalted) {
  auto tree = load_main(R"(<Sequence><Sleep msec="200"/><Act name="A"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.halt();
  EXPECT_EQ(tree.status(), kIdle);
  EXPECT_EQ(tree.tick_once(), kRunning);  // restarted: full 200 ms again
  clock.advance_ms(150);
  EXPECT_EQ(tree.tick_once(), kRunning);
  clock.advance_ms(60);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A");
}

}  // namespace
}  // namespace bt_test
