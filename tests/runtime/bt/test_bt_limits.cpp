// Limits and hostile input: deep SubTree chains, exponential SubTree fan-out, long cycles,
// non-UTF-8 attributes, <include> confinement, node paths without quadratic growth.
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::Diagnostic;
using visnav::bt::NodeStatus;

using Limits = BtTest;

// Concatenation without operator+ chains (GCC 12 reports a false -Wrestrict on those).
std::string cat(std::initializer_list<std::string_view> parts) {
  std::string out;
  for (std::string_view p : parts) out.append(p);
  return out;
}
std::string num(int i) { return std::to_string(i); }

std::string all(const std::vector<Diagnostic>& d) { return visnav::bt::to_string(d); }
bool has(const std::vector<Diagnostic>& d, const std::string& text) {
  for (const auto& x : d)
    if (x.str().find(text) != std::string::npos) return true;
  return false;
}

// T0 -> T1 -> ... -> T(n-1) -> leaf; `cycle` makes the last one call T0 instead.
std::string subtree_chain(int n, bool cycle = false) {
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"T0\">\n";
  for (int i = 0; i < n; ++i) {
    xml += cat({"<BehaviorTree ID=\"T", num(i), "\">"});
    if (i + 1 < n) {
      xml += cat({"<SubTree ID=\"T", num(i + 1), "\"/>"});
    } else {
      xml += cycle ? "<SubTree ID=\"T0\"/>" : "<AlwaysSuccess/>";
    }
    xml += "</BehaviorTree>\n";
  }
  return xml + "</root>\n";
}

TEST_F(Limits, ChainOf5000SubTreesIsAValidationErrorNotACrash) {
  const auto d = validate(subtree_chain(5000));
  ASSERT_EQ(d.size(), 2u) << all(d);  // SubTree depth and node depth
  EXPECT_EQ(d[0].code, visnav::ErrorCode::limit);
  EXPECT_EQ(d[1].code, visnav::ErrorCode::limit);
  // The message carries the measured depth and the chain: what the count got right.
  EXPECT_NE(d[0].message.find("SubTrees nest 4999 deep, more than the limit 64 (run.bt_max_subtree_depth): T0 -> T1 -> T2"),
            std::string::npos)
      << d[0].str();
  EXPECT_EQ(d[0].line, 2);  // the first <SubTree> of the chain
  EXPECT_NE(d[1].message.find("the expanded tree is 5000 nodes deep, more than the limit 1000"), std::string::npos)
      << d[1].str();
  auto tree = visnav::bt::load_tree_string(subtree_chain(5000), registry, options);
  EXPECT_FALSE(tree.ok());
}

TEST_F(Limits, ChainOf50000SubTreesAndA50000LongCycleValidateWithoutRecursion) {
  const auto d = validate(subtree_chain(50000));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[0].message.find("SubTrees nest 49999 deep"), std::string::npos);
  const auto c = validate(subtree_chain(50000, true));
  ASSERT_EQ(c.size(), 1u) << (c.empty() ? "" : c[0].str());
  EXPECT_EQ(c[0].code, visnav::ErrorCode::invalid_value) << c[0].str();
  EXPECT_NE(c[0].message.find("cyclic SubTree: T0 -> T1 -> "), std::string::npos);  // names the cycle
  EXPECT_NE(c[0].message.find("... -> "), std::string::npos);  // long cycles are abbreviated
}

TEST_F(Limits, SubTreeDepthLimitIsConfigurableAndExactlyTheLimitLoads) {
  options.max_subtree_depth = 3;
  EXPECT_TRUE(validate(subtree_chain(4)).empty());  // T0 -> T1 -> T2 -> T3: depth 3
  const auto d = validate(subtree_chain(5));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::limit) << d[0].str();
  EXPECT_NE(d[0].message.find("nest 4 deep, more than the limit 3"), std::string::npos) << d[0].str();
  auto tree = load(subtree_chain(4));
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
}

TEST_F(Limits, ExponentialSubTreeFanOutIsRejectedBeforeAnythingIsBuilt) {
  // 3 kB of XML, 2^40 nodes when expanded: validation must count, not expand.
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"L0\">\n";
  for (int i = 0; i < 40; ++i) {
    const std::string next = cat({"L", num(i + 1)});
    xml += cat({"<BehaviorTree ID=\"L", num(i), "\"><Sequence><SubTree ID=\"", next, "\"/><SubTree ID=\"", next,
                "\"/></Sequence></BehaviorTree>\n"});
  }
  xml += "<BehaviorTree ID=\"L40\"><AlwaysSuccess/></BehaviorTree>\n</root>\n";
  options.max_subtree_depth = 64;
  const auto d = validate(xml);
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::limit) << d[0].str();
  EXPECT_NE(d[0].message.find("the expanded tree would have 4398046511101 nodes, more than the limit 100000 (run.bt_max_nodes)"),
            std::string::npos)
      << d[0].str();
  // The count saturates instead of overflowing.
  std::string huge = "<root BTCPP_format=\"4\" main_tree_to_execute=\"L0\">\n";
  for (int i = 0; i < 80; ++i) {
    const std::string next = cat({"L", num(i + 1)});
    huge += cat({"<BehaviorTree ID=\"L", num(i), "\"><Sequence><SubTree ID=\"", next, "\"/><SubTree ID=\"", next,
                 "\"/></Sequence></BehaviorTree>\n"});
  }
  huge += "<BehaviorTree ID=\"L80\"><AlwaysSuccess/></BehaviorTree>\n</root>\n";
  options.max_subtree_depth = 100;
  const auto h = validate(huge);
  EXPECT_TRUE(has(h, "more than 4e18 nodes")) << all(h);
}

TEST_F(Limits, NodeLimitCountsSubTreeNodesAndIsConfigurable) {
  // Main: Sequence + 3 SubTree nodes, each expanding to Sequence + 2 leaves = 4 + 9 = 13 nodes.
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><Sequence><SubTree ID="S"/><SubTree ID="S"/><SubTree ID="S"/></Sequence></BehaviorTree>
  <BehaviorTree ID="S"><Sequence><AlwaysSuccess/><AlwaysSuccess/></Sequence></BehaviorTree>
</root>)";
  options.max_nodes = 13;
  auto tree = load(xml);
  EXPECT_EQ(tree.node_count(), 13u);
  options.max_nodes = 12;
  const auto d = validate(xml);
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::limit) << d[0].str();
  EXPECT_NE(d[0].message.find("would have 13 nodes, more than the limit 12"), std::string::npos) << d[0].str();
}

TEST_F(Limits, TreeDepthCountsThroughSubTrees) {
  // Each level: SubTree node + Inverter = 2 levels; 10 levels + leaf.
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"D0\">\n";
  for (int i = 0; i < 10; ++i)
    xml += cat({"<BehaviorTree ID=\"D", num(i), "\"><Inverter><SubTree ID=\"D", num(i + 1), "\"/></Inverter></BehaviorTree>\n"});
  xml += "<BehaviorTree ID=\"D10\"><AlwaysFailure/></BehaviorTree>\n</root>\n";
  options.max_tree_depth = 21;
  auto tree = load(xml);
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // ten inversions
  options.max_tree_depth = 20;
  const auto d = validate(xml);
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::limit) << d[0].str();
  EXPECT_NE(d[0].message.find("the expanded tree is 21 nodes deep, more than the limit 20 (run.bt_max_tree_depth)"),
            std::string::npos)
      << d[0].str();
}

TEST_F(Limits, DeepTreeLoadsTicksAndHasLinearPathStorage) {
  // 60 nested SubTrees (within the default depth 64), each adding a named component.
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"T0\">\n";
  for (int i = 0; i < 60; ++i)
    xml += cat({"<BehaviorTree ID=\"T", num(i), "\"><SubTree ID=\"T", num(i + 1), "\" name=\"s", num(i), "\"/></BehaviorTree>\n"});
  xml += "<BehaviorTree ID=\"T60\"><Act name=\"leaf\"/></BehaviorTree>\n</root>\n";
  auto tree = load(xml);
  EXPECT_EQ(tree.node_count(), 61u);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  std::string expected = "T0";
  for (int i = 0; i < 60; ++i) expected += cat({"/s", num(i)});
  expected += "/leaf";
  ASSERT_NE(tree.find_node(expected), nullptr);
  // Each node stores only its own component; the parent's path is shared.
  const auto* leaf = tree.find_node(expected);
  EXPECT_EQ(leaf->config().path->component, "leaf");
  EXPECT_EQ(leaf->config().path->parent.get(), tree.find_node(expected.substr(0, expected.size() - 5))->config().path.get());
}

TEST_F(Limits, NonUtf8AttributeValuesAreRejected) {
  const auto d = validate(main_tree("<Probe name=\"P\" s=\"caf\xC3\" out_i=\"{o}\" out_s=\"{s}\"/>"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:3: MainTree/P: attribute 's' is not valid UTF-8");
  const auto overlong = validate(main_tree("<Probe name=\"P\" s=\"\xC0\xAF\" out_i=\"{o}\" out_s=\"{s}\"/>"));
  EXPECT_EQ(overlong.size(), 1u) << all(overlong);
  EXPECT_TRUE(validate(main_tree("<Probe name=\"P\" s=\"caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80\" out_i=\"{o}\" out_s=\"{s}\"/>")).empty());
}

TEST_F(Limits, IncludeMustBeRelativeAndStayInsideTheTreeFolder) {
  TempDir dir;
  dir.write("outside.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="Out"><Act/></BehaviorTree></root>)");
  dir.write("trees/lib/inner.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="In"><Act/></BehaviorTree></root>)");
  const std::string abs = (dir.path() / "trees/lib/inner.xml").string();
  const auto main = dir.write("trees/main.xml", cat({"<root BTCPP_format=\"4\" main_tree_to_execute=\"M\">\n"
                                                     "<include path=\"../outside.xml\"/>\n"
                                                     "<include path=\"", abs, "\"/>\n"
                                                     "<include path=\"lib/../lib/inner.xml\"/>\n"
                                                     "<BehaviorTree ID=\"M\"><SubTree ID=\"In\"/></BehaviorTree>\n</root>\n"}));
  const auto d = visnav::bt::validate_tree_file(main, registry, options);
  ASSERT_EQ(d.size(), 2u) << all(d);
  EXPECT_EQ(d[0].line, 2);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::invalid_value) << d[0].str();
  EXPECT_NE(d[0].message.find("resolves outside the tree folder"), std::string::npos) << d[0].str();  // which rule
  EXPECT_EQ(d[1].line, 3);
  EXPECT_EQ(d[1].code, visnav::ErrorCode::invalid_value) << d[1].str();
  EXPECT_NE(d[1].message.find("absolute paths are not allowed"), std::string::npos) << d[1].str();
  // An explicit include_root widens the allowed folder.
  options.include_root = dir.path();
  const auto wide = visnav::bt::validate_tree_file(main, registry, options);
  ASSERT_EQ(wide.size(), 1u) << all(wide);
  EXPECT_NE(wide[0].message.find("absolute paths"), std::string::npos);
}

}  // namespace
}  // namespace bt_test
