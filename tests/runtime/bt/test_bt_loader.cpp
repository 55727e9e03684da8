// Loading: subtrees and remapping, include, main tree selection, and every validation error
// with its file:line and node path.
#include <algorithm>

#include "error_expect.hpp"
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::Diagnostic;
using visnav::bt::NodeStatus;

using Loader = BtTest;
using Validation = BtTest;

using visnav::ErrorCode;

std::string all(const std::vector<Diagnostic>& d) { return visnav::bt::to_string(d); }

// ---- SubTree -----------------------------------------------------------------------------------

using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST_F(Loader, SubTreeRemapsPortsBothWays) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree">
    <Sequence>
      <SetBlackboard value="5" output_key="in_val"/>
      <SubTree ID="Double" x="{in_val}" y="{out_val}"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Double">
    <Probe name="P" i="{x}" out_i="{y}" out_s="{local}"/>
  </BehaviorTree>
</root>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("out_val"), 10);
  EXPECT_FALSE(tree.blackboard().has("x"));
  EXPECT_FALSE(tree.blackboard().has("y"));
  EXPECT_FALSE(tree.blackboard().has("local"));  // not remapped: stays in the subtree
  auto* p = tree.find_node("MainTree/Sequence[0]/Double[1]/P");
  ASSERT_NE(p, nullptr);
  EXPECT_TRUE(p->blackboard().has("local"));
  EXPECT_EQ(tree.find_node("MainTree/Sequence[0]/Double[1]")->kind(), visnav::bt::NodeKind::subtree);
}

TEST_F(Loader, SubTreeLiteralAttributeIsWrittenIntoChildBlackboard) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree"><SubTree ID="Sub" x="21" result="{r}"/></BehaviorTree>
  <BehaviorTree ID="Sub"><Probe i="{x}" out_i="{result}" out_s="{s}"/></BehaviorTree>
</root>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("r"), 42);
}

TEST_F(Loader, SubTreeAutoremapSharesParentEntries) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree">
    <Sequence>
      <SetBlackboard value="3" output_key="i"/>
      <SubTree ID="Sub" _autoremap="true"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Sub"><Probe i="{i}" out_i="{doubled}" out_s="{_private}"/></BehaviorTree>
</root>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("doubled"), 6);
  EXPECT_FALSE(tree.blackboard().has("_private"));
}

TEST_F(Loader, SubTreeWithoutRemappingIsIsolated) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree">
    <Sequence>
      <SetBlackboard value="3" output_key="i"/>
      <SubTree ID="Sub"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Sub"><Probe i="{i}" out_i="{o}" out_s="{s}"/></BehaviorTree>
</root>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // {i} is not visible inside
  EXPECT_FALSE(tree.blackboard().has("o"));
}

TEST_F(Loader, RootReferenceReachesTheRootBlackboardFromNestedSubTrees) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree"><SubTree ID="A"/></BehaviorTree>
  <BehaviorTree ID="A"><SubTree ID="B"/></BehaviorTree>
  <BehaviorTree ID="B"><Probe i="{@gain}" out_i="{@result}" out_s="{s}"/></BehaviorTree>
</root>)");
  tree.blackboard().set("gain", 4);
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("result"), 8);
  EXPECT_NE(tree.find_node("MainTree/A[0]/B[0]/Probe[0]"), nullptr);
}

TEST_F(Loader, SubTreeIsHaltedWithItsParent) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree"><Sequence><SubTree ID="Sub"/></Sequence></BehaviorTree>
  <BehaviorTree ID="Sub"><Async name="R"/></BehaviorTree>
</root>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  tree.halt();
  EXPECT_EQ(world.take(), "R:start R:halt");
}

TEST_F(Loader, SameSubTreeUsedTwiceGetsSeparateInstances) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree"><Sequence><SubTree ID="Sub" name="first"/><SubTree ID="Sub" name="second"/></Sequence></BehaviorTree>
  <BehaviorTree ID="Sub"><Act name="A"/></BehaviorTree>
</root>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "A A");
  EXPECT_NE(tree.find_node("MainTree/Sequence[0]/first/A"), nullptr);
  EXPECT_NE(tree.find_node("MainTree/Sequence[0]/second/A"), nullptr);
  EXPECT_EQ(tree.node_count(), 5u);
}

// ---- main tree selection, include ------------------------------------------------------------

TEST_F(Loader, SingleTreeIsMainWithoutAttribute) {
  auto tree = load(R"(<root BTCPP_format="4"><BehaviorTree ID="Only"><Act name="A"/></BehaviorTree></root>)");
  EXPECT_EQ(tree.main_tree_id(), "Only");
}

TEST_F(Loader, OptionsOverrideMainTree) {
  options.main_tree = "Second";
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="First">
  <BehaviorTree ID="First"><Act name="A"/></BehaviorTree>
  <BehaviorTree ID="Second"><Act name="B"/></BehaviorTree>
</root>)");
  EXPECT_EQ(tree.main_tree_id(), "Second");
  tree.tick_once();
  EXPECT_EQ(world.take(), "B");
}

TEST_F(Loader, IncludeIsRelativeToTheIncludingFile) {
  TempDir dir;
  dir.write("lib/inner.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="Inner"><Act name="I"/></BehaviorTree></root>)");
  dir.write("lib/outer.xml", R"(<root BTCPP_format="4">
  <include path="inner.xml"/>
  <BehaviorTree ID="Outer"><Sequence><Act name="O"/><SubTree ID="Inner"/></Sequence></BehaviorTree>
</root>)");
  const auto main = dir.write("mission.xml", R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <include path="lib/outer.xml"/>
  <BehaviorTree ID="Main"><SubTree ID="Outer"/></BehaviorTree>
</root>)");
  auto tree = visnav::bt::load_tree_file(main, registry, options);
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  EXPECT_EQ(tree->tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "O I");
}

TEST_F(Loader, IncludeErrorsNameTheIncludedFile) {
  TempDir dir;
  dir.write("bad.xml", "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"Bad\">\n<Nope/>\n</BehaviorTree>\n</root>\n");
  const auto main = dir.write("main.xml", R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <include path="bad.xml"/>
  <include path="missing.xml"/>
  <BehaviorTree ID="Main"><SubTree ID="Bad"/></BehaviorTree>
</root>)");
  const auto d = visnav::bt::validate_tree_file(main, registry, options);
  ASSERT_EQ(d.size(), 2u) << all(d);
  EXPECT_EQ(d[0].str(), main.string() + ":3: cannot read included file '" + (dir.path() / "missing.xml").string() +
                           "': no such tree file");
  EXPECT_EQ(d[0].code, ErrorCode::not_found);
  EXPECT_EQ(d[1].str(), (dir.path() / "bad.xml").string() + ":3: Bad/Nope[0]: unknown node ID 'Nope'");
}

TEST_F(Loader, CyclicIncludeIsAnError) {
  TempDir dir;
  dir.write("a.xml", R"(<root BTCPP_format="4"><include path="b.xml"/><BehaviorTree ID="A"><Act/></BehaviorTree></root>)");
  dir.write("b.xml", R"(<root BTCPP_format="4"><include path="a.xml"/></root>)");
  const auto d = visnav::bt::validate_tree_file(dir.path() / "a.xml", registry, options);
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::invalid_value) << all(d);
  EXPECT_EQ(d[0].file, (dir.path() / "b.xml").string()) << all(d);
  EXPECT_EQ(d[0].line, 1) << all(d);
}

TEST_F(Loader, MissingFileIsAnError) {
  auto tree = visnav::bt::load_tree_file("/nonexistent/mission.xml", registry, options);
  EXPECT_TRUE(fails_with(tree, ErrorCode::not_found, At{"/nonexistent/mission.xml"}));
}

TEST_F(Loader, TreeNodesModelAndGenericActionElementAreAccepted) {
  auto tree = load(R"(<root BTCPP_format="4">
  <BehaviorTree ID="Main"><Sequence><Action ID="Act" name="A"/><Condition ID="Cond" name="C"/></Sequence></BehaviorTree>
  <TreeNodesModel><Action ID="Act"/></TreeNodesModel>
</root>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "A C");
}

// ---- validation errors ---------------------------------------------------------------------------

TEST_F(Validation, MalformedXmlReportsLine) {
  const auto d = validate("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"M\">\n<Sequence>\n</BehaviorTree>\n</root>\n");
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].file, "<string>");
  EXPECT_GE(d[0].line, 3);
  EXPECT_EQ(d[0].code, ErrorCode::parse_error) << all(d);
}

TEST_F(Validation, UnknownNodeId) {
  const auto d = validate(main_tree("<Sequence>\n  <Act/>\n  <Teleport name=\"beam\"/>\n</Sequence>"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:5: MainTree/Sequence[0]/beam: unknown node ID 'Teleport'");
}

TEST_F(Validation, MissingRequiredPort) {
  const auto d = validate(main_tree("<Repeat><Act/></Repeat>"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/Repeat[0]: missing required port 'num_cycles' (int)");
}

TEST_F(Validation, UnknownPortAttribute) {
  const auto d = validate(main_tree(R"(<Timeout msec="5" msecs="10"><Act/></Timeout>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/Timeout[0]: unknown port 'msecs' for Timeout (ports: msec)");
}

TEST_F(Validation, UnknownUnderscoreAttributesAreErrorsNamingTheAttribute) {
  const auto d = validate(main_tree(R"(<Act _skipIf="x == 1" _frobnicate="1"/>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::unknown_key) << all(d);
  EXPECT_EQ(d[0].line, 3) << all(d);
  EXPECT_EQ(d[0].node_path, "MainTree/Act[0]") << all(d);
}

TEST_F(Validation, MetadataAttributesWrittenByGroot2AreIgnored) {
  const auto d = validate(main_tree(
      R"(<Sequence _description="patrol" _uid="3"><Act _fullpath="MainTree/Act" _description="go"/></Sequence>)"));
  EXPECT_TRUE(d.empty()) << all(d);
}

TEST_F(Validation, BadLiteralForPortType) {
  const auto d = validate(main_tree(R"(<Sleep msec="soon"/>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(),
            "<string>:3: MainTree/Sleep[0]: port 'msec': bad value for type unsigned int: 'soon' is not an unsigned integer");
  // msec is unsigned, as in BehaviorTree.CPP: a negative literal is rejected at validation.
  const auto neg = validate(main_tree(R"(<Sleep msec="-5"/>)"));
  ASSERT_EQ(neg.size(), 1u) << all(neg);
  EXPECT_EQ(neg[0].code, ErrorCode::invalid_value) << all(neg);
  EXPECT_EQ(neg[0].line, 3) << all(neg);
}

TEST_F(Validation, UndefinedSubTree) {
  const auto d = validate(main_tree(R"(<SubTree ID="Elsewhere"/>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/Elsewhere[0]: undefined SubTree 'Elsewhere'");
}

TEST_F(Validation, CyclicSubTree) {
  const auto d = validate(R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><SubTree ID="A"/></BehaviorTree>
<BehaviorTree ID="A"><Sequence><Act/><SubTree ID="B"/></Sequence></BehaviorTree>
<BehaviorTree ID="B"><SubTree ID="A" name="back"/></BehaviorTree>
</root>)");
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:4: B/back: cyclic SubTree: A -> B -> A");
}

TEST_F(Validation, SelfRecursiveSubTree) {
  const auto d = validate(main_tree(R"(<Fallback><Act/><SubTree ID="MainTree"/></Fallback>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::invalid_value) << all(d);
  EXPECT_EQ(d[0].line, 3) << all(d);
}

TEST_F(Validation, DecoratorWithTwoChildren) {
  const auto d = validate(main_tree(R"(<Inverter><Act/><Act/></Inverter>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/Inverter[0]: decorator Inverter needs exactly 1 child, has 2");
}

TEST_F(Validation, DecoratorWithoutChild) {
  const auto d = validate(main_tree(R"(<ForceSuccess/>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::invalid_value) << all(d);
  EXPECT_EQ(d[0].node_path, "MainTree/ForceSuccess[0]") << all(d);
}

TEST_F(Validation, LeafWithChildren) {
  const auto d = validate(main_tree(R"(<Act name="A"><Act/></Act>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/A: action Act cannot have children, has 1");
}

TEST_F(Validation, ControlWithoutChildren) {
  const auto d = validate(main_tree(R"(<Sequence/>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/Sequence[0]: control node Sequence needs at least 1 child, has 0");
}

TEST_F(Validation, ChildCountRulesOfIfThenElseAndSwitch) {
  const auto d = validate(main_tree(R"(<Sequence>
<IfThenElse><Cond/></IfThenElse>
<Switch2 variable="a" case_1="a" case_2="b"><Act/><Act/></Switch2>
</Sequence>)"));
  ASSERT_EQ(d.size(), 2u) << all(d);
  EXPECT_EQ(d[0].line, 4) << all(d);
  EXPECT_EQ(d[1].line, 5) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::invalid_value);
  EXPECT_EQ(d[1].code, ErrorCode::invalid_value);
}

TEST_F(Validation, MissingAndExtraRootAttributes) {
  // Like BehaviorTree.CPP (which only warns), a <root> without BTCPP_format is accepted.
  const auto d1 = validate(R"(<root><BehaviorTree ID="M"><Act/></BehaviorTree></root>)");
  EXPECT_TRUE(d1.empty()) << all(d1);
  const auto d2 = validate(R"(<root BTCPP_format="3" colour="blue"><BehaviorTree ID="M"><Act/></BehaviorTree></root>)");
  ASSERT_EQ(d2.size(), 2u) << all(d2);
  EXPECT_EQ(d2[0].code, ErrorCode::parse_error) << all(d2);
  EXPECT_EQ(d2[1].code, ErrorCode::unknown_key) << all(d2);
}

TEST_F(Validation, WrongRootElement) {
  const auto d = validate(R"(<tree BTCPP_format="4"/>)");
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::parse_error) << all(d);
  EXPECT_EQ(d[0].line, 1) << all(d);
}

TEST_F(Validation, MainTreeSelectionErrors) {
  const auto d1 = validate(R"(<root BTCPP_format="4" main_tree_to_execute="Nope"><BehaviorTree ID="M"><Act/></BehaviorTree></root>)");
  ASSERT_EQ(d1.size(), 1u) << all(d1);
  EXPECT_EQ(d1[0].code, ErrorCode::not_found) << all(d1);
  const auto d2 = validate(R"(<root BTCPP_format="4">
<BehaviorTree ID="A"><Act/></BehaviorTree>
<BehaviorTree ID="B"><Act/></BehaviorTree></root>)");
  ASSERT_EQ(d2.size(), 1u) << all(d2);
  EXPECT_EQ(d2[0].code, ErrorCode::missing) << all(d2);
  EXPECT_EQ(d2[0].line, 1) << all(d2);
}

TEST_F(Validation, BehaviorTreeStructureErrors) {
  const auto d = validate(R"(<root BTCPP_format="4" main_tree_to_execute="A">
<BehaviorTree ID="A"><Act/><Act/></BehaviorTree>
<BehaviorTree ID="A"><Act/></BehaviorTree>
<BehaviorTree><Act/></BehaviorTree>
<Sequence/>
</root>)");
  ASSERT_EQ(d.size(), 4u) << all(d);
  EXPECT_EQ(d[0].line, 3);
  EXPECT_EQ(d[0].code, ErrorCode::inconsistent) << all(d);
  EXPECT_EQ(d[1].code, ErrorCode::missing) << all(d);
  EXPECT_EQ(d[1].line, 4) << all(d);
  EXPECT_EQ(d[2].code, ErrorCode::parse_error) << all(d);
  EXPECT_EQ(d[2].line, 5) << all(d);
  EXPECT_EQ(d[3].code, ErrorCode::invalid_value) << all(d);
  EXPECT_EQ(d[3].line, 2) << all(d);
}

TEST_F(Validation, AllErrorsAreCollectedAndNothingIsInstantiated) {
  int constructed = 0;
  struct Counted final : visnav::bt::SyncActionNode {
    Counted(const std::string& n, const NodeConfig& c, int& count) : SyncActionNode(n, c) { ++count; }
    NodeStatus tick() override { return NodeStatus::success; }
  };
  ASSERT_TRUE(registry
                  .register_node<Counted>("Counted", "",
                                          [&constructed](const std::string& n, const NodeConfig& c) {
                                            return std::make_unique<Counted>(n, c, constructed);
                                          })
                  .ok());
  const std::string xml = main_tree(R"(<Sequence>
  <Counted/>
  <Unknown/>
  <Repeat><Counted/></Repeat>
  <Sleep msec="x" bogus="1"/>
  <SubTree ID="Missing"/>
</Sequence>)");
  auto tree = visnav::bt::load_tree_string(xml, registry, options);
  ASSERT_FALSE(tree.ok());
  EXPECT_EQ(constructed, 0);
  const std::string& m = tree.error().message;
  EXPECT_EQ(std::count(m.begin(), m.end(), '\n'), 4) << m;  // five errors, one per line
  EXPECT_NE(m.find("<string>:5: MainTree/Sequence[0]/Unknown[1]: unknown node ID 'Unknown'"), std::string::npos) << m;
  EXPECT_NE(m.find("<string>:6: MainTree/Sequence[0]/Repeat[2]: missing required port 'num_cycles'"), std::string::npos) << m;
  EXPECT_NE(m.find("<string>:7: MainTree/Sequence[0]/Sleep[3]: unknown port 'bogus'"), std::string::npos) << m;
  EXPECT_NE(m.find("<string>:7: MainTree/Sequence[0]/Sleep[3]: port 'msec'"), std::string::npos) << m;
  EXPECT_NE(m.find("<string>:8: MainTree/Sequence[0]/Missing[4]: undefined SubTree 'Missing'"), std::string::npos) << m;
  // Valid again: builds.
  auto ok_tree = visnav::bt::load_tree_string(main_tree("<Counted/>"), registry, options);
  ASSERT_TRUE(ok_tree.ok());
  EXPECT_EQ(constructed, 1);
}

TEST_F(Validation, DiagnosticsFromAFileNameTheFile) {
  TempDir dir;
  const auto file = dir.write("m.xml", main_tree("<Sequence>\n<Unknown/>\n</Sequence>"));
  const auto d = visnav::bt::validate_tree_file(file, registry, options);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].file, file.string());
  EXPECT_EQ(d[0].line, 4);
  EXPECT_TRUE(visnav::bt::validate_tree_file(dir.write("ok.xml", main_tree("<Act/>")), registry, options).empty());
}


// ---- Port overrides (visnav run/experiment --port, visnav tune) ------------------------------

TEST_F(Loader, PortOverridesReplaceAndAddAttributesOnEveryNodeOfTheTypeIncludedFilesToo) {
  TempDir dir;
  dir.write("sub.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="Sub"><Probe name="Q" i="1" out_i="{q}" out_s="{qs}"/></BehaviorTree></root>)");
  const auto main_file = dir.write("main.xml", R"(<root BTCPP_format="4" main_tree_to_execute="M">
  <include path="sub.xml"/>
  <BehaviorTree ID="M"><Sequence>
    <Probe name="P" i="2" out_i="{p}" out_s="{ps}"/>
    <Action ID="Probe" name="G" out_i="{g}" out_s="{gs}"/>
    <SubTree ID="Sub" q="{q}"/>
  </Sequence></BehaviorTree>
</root>)");
  options.port_overrides = {{"Probe", "i", "20"}, {"Probe", "s", "tuned"}};
  auto tree = visnav::bt::load_tree_file(main_file, registry, options);
  ASSERT_TRUE(tree) << tree.error().message;
  ASSERT_EQ(tree->tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree->blackboard().get<int>("p"), 40);  // replaced
  EXPECT_EQ(*tree->blackboard().get<int>("g"), 40);  // added to the generic <Action ID="Probe">
  EXPECT_EQ(*tree->blackboard().get<int>("q"), 40);  // in the included file
  EXPECT_EQ(*tree->blackboard().get<std::string>("ps"), "tuned!");
}

TEST_F(Validation, APortOverrideForAMissingNodeOrPortIsAnErrorNeverIgnored) {
  options.port_overrides = {{"Prob", "i", "3"}};
  auto d = validate(main_tree("<Probe i=\"1\"/>"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, ErrorCode::not_found) << all(d);
  EXPECT_EQ(d[0].node_path, "Prob.i");
  options.port_overrides = {{"Probe", "gain", "3"}};
  d = validate(main_tree("<Probe i=\"1\"/>"));
  ASSERT_FALSE(d.empty());
  EXPECT_NE(all(d).find("gain"), std::string::npos) << all(d);  // the usual unknown-port diagnostic
  options.port_overrides = {{"Probe", "i", "many"}};
  EXPECT_FALSE(validate(main_tree("<Probe i=\"1\"/>")).empty());  // the value is checked like XML
}

TEST(PortOverrideText, ParsesNodePortValueAndRejectsOtherShapes) {
  auto o = visnav::bt::parse_port_override("ReplayFeatureEdge.gain=0.5");
  ASSERT_TRUE(o) << o.error().message;
  EXPECT_EQ(o->node, "ReplayFeatureEdge");
  EXPECT_EQ(o->port, "gain");
  EXPECT_EQ(o->value, "0.5");
  EXPECT_EQ(visnav::bt::parse_port_override("Node.p=")->value, "");
  for (const char* bad : {"gain=0.5", ".gain=1", "Node.=1", "Node.gain"}) {
    auto r = visnav::bt::parse_port_override(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::parse_error) << bad;
  }
}

}  // namespace
}  // namespace bt_test
