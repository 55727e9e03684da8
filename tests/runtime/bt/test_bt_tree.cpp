// Tree-level behaviour: observers, trace file, halting on destruction, tick_while_running,
// visitor, and the TreeNodesModel export.
#include <sstream>

#include "error_expect.hpp"
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::NodeStatus;
using TreeTest = BtTest;

std::vector<std::string> read_lines(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST_F(TreeTest, ObserverSeesEveryTransitionInOrder) {
  auto tree = load_main(R"(<Sequence><Act name="A"/><Async name="B"/></Sequence>)");
  std::vector<std::string> seen;
  const auto id = tree.add_observer([&](double, const visnav::bt::TreeNode& n, NodeStatus from, NodeStatus to) {
    seen.push_back(n.name() + ":" + visnav::bt::to_string(from) + ">" + visnav::bt::to_string(to));
  });
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(seen, (std::vector<std::string>{"Sequence:IDLE>RUNNING", "A:IDLE>SUCCESS", "B:IDLE>RUNNING"}));
  seen.clear();
  tree.halt();
  EXPECT_EQ(seen, (std::vector<std::string>{"A:SUCCESS>IDLE", "B:RUNNING>IDLE", "Sequence:RUNNING>IDLE"}));
  seen.clear();
  tree.remove_observer(id);
  tree.tick_once();
  EXPECT_TRUE(seen.empty());
}

TEST_F(TreeTest, TraceWriterWritesJsonLines) {
  TempDir dir;
  const auto file = dir.path() / "trace.jsonl";
  auto tree = load_main(R"(<Sequence><Act name="A"/><Sleep msec="100"/></Sequence>)");
  {
    auto trace = visnav::bt::TraceWriter::attach(tree, file);
    ASSERT_TRUE(trace.ok()) << trace.error().message;
    clock.t_s = 1.5;
    EXPECT_EQ(tree.tick_once(), NodeStatus::running);
    clock.t_s = 1.75;
    EXPECT_EQ(tree.tick_once(), NodeStatus::success);
    EXPECT_EQ((*trace)->lines_written(), 7u);
  }
  const auto lines = read_lines(file);
  ASSERT_EQ(lines.size(), 7u);
  EXPECT_EQ(lines[0], R"({"t":1.500000,"node":"MainTree/Sequence[0]","from":"IDLE","to":"RUNNING"})");
  EXPECT_EQ(lines[1], R"({"t":1.500000,"node":"MainTree/Sequence[0]/A","from":"IDLE","to":"SUCCESS"})");
  EXPECT_EQ(lines[2], R"({"t":1.500000,"node":"MainTree/Sequence[0]/Sleep[1]","from":"IDLE","to":"RUNNING"})");
  EXPECT_EQ(lines[3], R"({"t":1.750000,"node":"MainTree/Sequence[0]/Sleep[1]","from":"RUNNING","to":"SUCCESS"})");
  EXPECT_EQ(lines[4], R"({"t":1.750000,"node":"MainTree/Sequence[0]/A","from":"SUCCESS","to":"IDLE"})");
  EXPECT_EQ(lines[6], R"({"t":1.750000,"node":"MainTree/Sequence[0]","from":"RUNNING","to":"SUCCESS"})");
  // Detached: further ticks are not written.
  tree.tick_once();
  EXPECT_EQ(read_lines(file).size(), 7u);
}

TEST_F(TreeTest, TraceWriterReportsUnwritableFile) {
  auto tree = load_main(R"(<Act/>)");
  auto trace = visnav::bt::TraceWriter::attach(tree, "/nonexistent/dir/trace.jsonl");
  EXPECT_TRUE(fails_with(trace, ErrorCode::io, At{"/nonexistent/dir/trace.jsonl"}));
}

TEST_F(TreeTest, DestroyingARunningTreeHaltsIt) {
  {
    auto tree = load_main(R"(<Parallel><Async name="A"/><Async name="B"/></Parallel>)");
    EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  }
  EXPECT_EQ(world.take(), "A:start B:start A:halt B:halt");
}

TEST_F(TreeTest, MovedTreeKeepsWorking) {
  auto tree = load_main(R"(<Sequence><Act name="A"/><Async name="B"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  visnav::bt::Tree moved = std::move(tree);
  EXPECT_EQ(moved.tick_once(), NodeStatus::running);
  EXPECT_EQ(world.take(), "A B:start B:run");
}

class SteppingClock final : public visnav::Clock {
 public:
  [[nodiscard]] double now_s() const override { return t_s += 0.01; }
  mutable double t_s = 0.0;
};

TEST_F(TreeTest, TickWhileRunningTicksUntilDone) {
  SteppingClock stepping;
  options.clock = &stepping;
  auto tree = load_main(R"(<Sequence><Sleep msec="50"/><Act name="A"/></Sequence>)");
  EXPECT_EQ(tree.tick_while_running(std::chrono::nanoseconds(0)), NodeStatus::success);
  EXPECT_EQ(world.take(), "A");
  EXPECT_EQ(&tree.clock(), &stepping);
}

TEST_F(TreeTest, VisitIsDepthFirstInChildOrder) {
  auto tree = load_main(R"(<Sequence><Fallback><Act name="A"/><Act name="B"/></Fallback><Inverter><Act name="C"/></Inverter></Sequence>)");
  std::vector<std::string> paths;
  tree.visit([&](visnav::bt::TreeNode& n) { paths.push_back(n.path()); });
  EXPECT_EQ(paths, (std::vector<std::string>{"MainTree/Sequence[0]", "MainTree/Sequence[0]/Fallback[0]",
                                             "MainTree/Sequence[0]/Fallback[0]/A", "MainTree/Sequence[0]/Fallback[0]/B",
                                             "MainTree/Sequence[0]/Inverter[1]", "MainTree/Sequence[0]/Inverter[1]/C"}));
  EXPECT_EQ(tree.node_count(), 6u);
  const auto& root = tree.root();
  EXPECT_EQ(root.registration_id(), "Sequence");
  EXPECT_EQ(root.kind(), visnav::bt::NodeKind::control);
  EXPECT_EQ(root.where().line, 3);
}

TEST_F(TreeTest, RootCanBeRestartedAfterCompletion) {
  auto tree = load_main(R"(<Sequence><Act name="A"/></Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(tree.status(), NodeStatus::success);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "A A");
}

TEST_F(TreeTest, HostProvidedBlackboardIsTheRoot) {
  auto bb = visnav::bt::Blackboard::create();
  bb->set("n", 9);
  options.blackboard = bb;
  auto tree = load_main(R"(<Probe i="{n}" out_i="{twice}" out_s="{s}"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*bb->get<int>("twice"), 18);
  EXPECT_EQ(tree.blackboard_ptr(), bb);
}

TEST_F(TreeTest, ExceptionInTickHaltsTheTreeAndIsReported) {
  struct Thrower final : visnav::bt::SyncActionNode {
    using SyncActionNode::SyncActionNode;
    NodeStatus tick() override { throw std::runtime_error("boom"); }
  };
  ASSERT_TRUE(registry.register_node<Thrower>("Thrower").ok());
  auto tree = load_main(R"(<Parallel><Async name="A"/><Thrower/></Parallel>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_EQ(tree.last_error(), "exception during tick: boom");
  EXPECT_EQ(world.take(), "A:start A:halt");
  tree.visit([](visnav::bt::TreeNode& n) { EXPECT_EQ(n.status(), NodeStatus::idle) << n.path(); });
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // the tree stays usable
  EXPECT_EQ(world.take(), "A:start A:halt");
}

// ---- nodes model ---------------------------------------------------------------------------------

TEST_F(TreeTest, NodesModelListsPortsWithTypesDefaultsAndDescriptions) {
  const std::string xml = visnav::bt::write_nodes_model(registry);
  EXPECT_NE(xml.find("<root BTCPP_format=\"4\">"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<TreeNodesModel>"), std::string::npos);
  EXPECT_NE(xml.find("<Action ID=\"Probe\">"), std::string::npos);
  EXPECT_NE(xml.find("<input_port name=\"i\" type=\"int\" default=\"7\">an int</input_port>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<input_port name=\"color\" type=\"Color\" default=\"green\">an enum</input_port>"), std::string::npos);
  EXPECT_NE(xml.find("<input_port name=\"vd\" type=\"std::vector&lt;double&gt;\" default=\"\">double list</input_port>"),
            std::string::npos);
  EXPECT_NE(xml.find("<output_port name=\"out_i\" type=\"int\">an int output</output_port>"), std::string::npos);
  EXPECT_NE(xml.find("<Condition ID=\"Cond\">"), std::string::npos);
  EXPECT_NE(xml.find("<Control ID=\"Sequence\">"), std::string::npos);
  EXPECT_NE(xml.find("<Decorator ID=\"Timeout\">"), std::string::npos);
  EXPECT_NE(xml.find("<inout_port name=\"output_key\" type=\"BT::AnyTypeAllowed\">"), std::string::npos);
  EXPECT_NE(xml.find("<description>port probe</description>"), std::string::npos);
}

TEST_F(TreeTest, NodesModelCanLeaveBuiltinsOutAndIsValidXmlForTheLoader) {
  const std::string xml = visnav::bt::write_nodes_model(registry, false);
  EXPECT_EQ(xml.find("ID=\"Sequence\""), std::string::npos);
  EXPECT_NE(xml.find("ID=\"Probe\""), std::string::npos);
  // The model embedded in a tree file is accepted (and ignored) by the loader.
  std::string with_tree = xml;
  const auto pos = with_tree.find("<TreeNodesModel>");
  ASSERT_NE(pos, std::string::npos);
  with_tree.insert(pos, "<BehaviorTree ID=\"M\"><Act/></BehaviorTree>");
  EXPECT_TRUE(validate(with_tree).empty()) << visnav::bt::to_string(validate(with_tree));
}

TEST_F(TreeTest, RegistryListsManifestsSorted) {
  const auto manifests = registry.manifests();
  ASSERT_FALSE(manifests.empty());
  EXPECT_TRUE(std::is_sorted(manifests.begin(), manifests.end(),
                             [](const auto* a, const auto* b) { return a->id < b->id; }));
  const auto* parallel = registry.find("Parallel");
  ASSERT_NE(parallel, nullptr);
  EXPECT_TRUE(parallel->builtin);
  EXPECT_EQ(parallel->kind, visnav::bt::NodeKind::control);
  ASSERT_EQ(parallel->ports.size(), 2u);
  EXPECT_EQ(parallel->ports[0].default_value, "-1");
  EXPECT_FALSE(registry.find("Probe")->builtin);
  for (const char* id : {"Sequence", "SequenceWithMemory", "ReactiveSequence", "Fallback", "ReactiveFallback", "Parallel",
                         "IfThenElse", "WhileDoElse", "Switch2", "Switch3", "Switch4", "Switch5", "Switch6", "Inverter",
                         "ForceSuccess", "ForceFailure", "Repeat", "RetryUntilSuccessful", "Timeout", "Delay", "RunOnce",
                         "KeepRunningUntilFailure", "AlwaysSuccess", "AlwaysFailure", "SetBlackboard", "Sleep"})
    EXPECT_NE(registry.find(id), nullptr) << id;
}

}  // namespace
}  // namespace bt_test
