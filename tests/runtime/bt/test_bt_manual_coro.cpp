// ManualSelector (the operator's choice through the blackboard) and CoroActionNode (actions
// written as one C++20 coroutine, BehaviorTree.CPP's CoroActionNode semantics).
#include <memory>
#include <stdexcept>

#include "bt_test_support.hpp"
#include "visnav/bt/coro_action.hpp"

namespace bt_test {
namespace {

using visnav::bt::CoroTask;
using visnav::bt::NodeStatus;
constexpr NodeStatus kIdle = NodeStatus::idle;
constexpr NodeStatus kRunning = NodeStatus::running;
constexpr NodeStatus kSuccess = NodeStatus::success;
constexpr NodeStatus kFailure = NodeStatus::failure;
constexpr NodeStatus kSkipped = NodeStatus::skipped;

// ---- ManualSelector ---------------------------------------------------------------------------

using Manual = BtTest;

constexpr const char* kThreeChoices =
    R"(<ManualSelector><Act name="A"/><Async name="B"/><Act name="C"/></ManualSelector>)";

TEST_F(Manual, WaitsWhileNoChoiceThenTicksTheChosenChildByNameAndConsumesTheChoice) {
  auto tree = load_main(kThreeChoices);
  EXPECT_EQ(tree.tick_once(), kRunning);  // nothing chosen yet
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "");
  tree.blackboard().set("manual_selection", std::string("C"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "C");
  EXPECT_FALSE(tree.blackboard().has("manual_selection"));  // used once
  EXPECT_EQ(tree.tick_once(), kRunning);                     // waits for the next choice
  EXPECT_EQ(world.take(), "");
}

TEST_F(Manual, ChoiceByIndexAndARunningChildIsResumedWithoutANewChoice) {
  world.push("B", {kRunning, kRunning, kFailure});
  auto tree = load_main(kThreeChoices);
  tree.blackboard().set("manual_selection", std::string("1"));
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "B:start B:run B:run");
}

TEST_F(Manual, StatusChoicesReturnThatStatusAndAnUnknownChoiceFails) {
  auto tree = load_main(kThreeChoices);
  tree.blackboard().set("manual_selection", std::string("SUCCESS"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  tree.blackboard().set("manual_selection", std::string("FAILURE"));
  EXPECT_EQ(tree.tick_once(), kFailure);
  tree.blackboard().set("manual_selection", std::string("SKIPPED"));
  EXPECT_EQ(tree.tick_once(), kSkipped);
  tree.blackboard().set("manual_selection", std::string("D"));  // no such child
  EXPECT_EQ(tree.tick_once(), kFailure);
  tree.blackboard().set("manual_selection", std::string("3"));  // index out of range
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "");
}

TEST_F(Manual, RepeatLastSelectionReusesTheChoiceWithoutWaiting) {
  auto tree = load_main(
      R"(<ManualSelector selection="{pick}" repeat_last_selection="true"><Act name="A"/><Act name="B"/></ManualSelector>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.blackboard().set("pick", std::string("B"));
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "B B B");
}

TEST_F(Manual, HaltHaltsTheRunningChildAndTheNextRunWaitsForANewChoice) {
  auto tree = load_main(kThreeChoices);
  tree.blackboard().set("manual_selection", std::string("B"));
  EXPECT_EQ(tree.tick_once(), kRunning);
  tree.halt();
  EXPECT_EQ(world.take(), "B:start B:halt");
  EXPECT_EQ(tree.status(), kIdle);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "");  // choice consumed: waiting again
}

TEST_F(Manual, ALiteralSelectionIsAFixedChoiceAndTheTypeOfTheKeyIsChecked) {
  auto tree = load_main(R"(<ManualSelector selection="A"><Act name="A"/><Act name="B"/></ManualSelector>)");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "A A");
  // `selection` is a std::string port: the key cannot also be an int elsewhere.
  const auto d = validate(main_tree(
      R"(<Sequence><Probe name="P" out_i="{manual_selection}" out_s="{s}"/><ManualSelector><Act name="A"/></ManualSelector></Sequence>)"));
  ASSERT_EQ(d.size(), 1u) << visnav::bt::to_string(d);
  EXPECT_NE(d[0].message.find("blackboard key 'manual_selection'"), std::string::npos) << d[0].str();
}

// ---- CoroActionNode ---------------------------------------------------------------------------

/// Counts destructions of the locals a coroutine holds at a yield point.
struct Guard {
  World* world;
  std::string what;
  ~Guard() { world->log.push_back("~" + what); }
};

/// Steps through `steps` ticks (port), logging each; succeeds, or fails when fail="true".
class Stepper final : public visnav::bt::CoroActionNode {
 public:
  Stepper(const std::string& name, const visnav::bt::NodeConfig& config, World& world)
      : CoroActionNode(name, config), world_(world) {}
  static visnav::bt::PortsList provided_ports() {
    return {visnav::bt::input_port<int>("steps", "2", "ticks to take"),
            visnav::bt::input_port<bool>("fail", "false", "end with failure"),
            visnav::bt::input_port<bool>("throw", "false", "throw at the end (a bug)")};
  }

 protected:
  CoroTask run() override {
    const int steps = get_input<int>("steps").value_or(0);
    Guard guard{&world_, name()};
    for (int i = 0; i < steps; ++i) {
      world_.log.push_back(name() + ":" + std::to_string(i));
      co_await yield_running();
    }
    if (get_input<bool>("throw").value_or(false)) throw std::runtime_error("stepper bug");
    co_return get_input<bool>("fail").value_or(false) ? NodeStatus::failure : NodeStatus::success;
  }
  void on_halted() override { world_.log.push_back(name() + ":halted"); }

 private:
  World& world_;
};

class Coro : public BtTest {
 protected:
  Coro() {
    EXPECT_TRUE(registry
                    .register_node<Stepper>("Stepper", "coroutine test action",
                                            [this](const std::string& name, const visnav::bt::NodeConfig& config) {
                                              return std::make_unique<Stepper>(name, config, world);
                                            })
                    .ok());
  }
};

TEST_F(Coro, YieldsRunningOncePerStepAndResumesWhereItStopped) {
  auto tree = load_main(R"(<Stepper name="S" steps="3"/>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:0");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:1");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:2");
  EXPECT_EQ(tree.tick_once(), kSuccess);
  EXPECT_EQ(world.take(), "~S");  // the frame ends with the action
  // The next run starts from the beginning.
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:0");
}

TEST_F(Coro, CompletesInOneTickWithoutYieldingAndReportsFailure) {
  auto tree = load_main(R"(<Stepper name="S" steps="0" fail="true"/>)");
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "~S");
}

TEST_F(Coro, HaltDestroysTheSuspendedFrameThenCallsOnHaltedAndTheNextTickRestarts) {
  auto tree = load_main(R"(<Sequence><Stepper name="S" steps="5"/><Act name="after"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:0 S:1");
  tree.halt();
  EXPECT_EQ(world.take(), "~S S:halted");  // locals destroyed (RAII), then on_halted
  EXPECT_EQ(tree.status(), kIdle);
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(world.take(), "S:0");
}

TEST_F(Coro, AReactiveParentHaltsItWhenAnEarlierChildFails) {
  world.push("C", {kSuccess, kFailure});
  auto tree = load_main(R"(<ReactiveSequence><Cond name="C"/><Stepper name="S" steps="3"/></ReactiveSequence>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_EQ(world.take(), "C S:0 C ~S S:halted");
}

TEST_F(Coro, AnExceptionEscapingTheCoroutineReachesTheTree) {
  auto tree = load_main(R"(<Stepper name="S" steps="1" throw="true"/>)");
  EXPECT_EQ(tree.tick_once(), kRunning);
  EXPECT_EQ(tree.tick_once(), kFailure);
  EXPECT_NE(tree.last_error().find("stepper bug"), std::string::npos) << tree.last_error();
  EXPECT_EQ(world.take(), "S:0 ~S S:halted");  // the tree halts every RUNNING node
}

TEST_F(Coro, DestroyingATreeWithASuspendedCoroutineFreesItsFrame) {
  {
    auto tree = load_main(R"(<Stepper name="S" steps="3"/>)");
    EXPECT_EQ(tree.tick_once(), kRunning);
  }
  EXPECT_EQ(world.take(), "S:0 ~S S:halted");  // ~Tree halts the RUNNING action
}

}  // namespace
}  // namespace bt_test
