// Ports: literal conversion of every type, defaults, bad literals, blackboard references,
// the blackboard itself and registry rules.
#include "error_expect.hpp"
#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::Blackboard;
using visnav::bt::NodeStatus;
using visnav::bt::convert_from_string;

using Ports = BtTest;

bool any_contains(const std::vector<visnav::bt::Diagnostic>& d, const std::string& text) {
  for (const auto& x : d)
    if (x.str().find(text) != std::string::npos) return true;
  return false;
}

Probe* find_probe(visnav::bt::Tree& tree, const std::string& path) {
  return dynamic_cast<Probe*>(tree.find_node(path));
}

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST_F(Ports, LiteralsOfEveryTypeAreConverted) {
  auto tree = load_main(
      R"(<Probe name="P" i="-42" d="-1.5e3" b="true" s="some text" color="blue" vi="4;5;-6" vd="0.5; 1.5" vs="x;y z;" out_i="{oi}" out_s="{os}"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  Probe* p = find_probe(tree, "MainTree/P");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->i, -42);
  EXPECT_DOUBLE_EQ(p->d, -1500.0);
  EXPECT_TRUE(p->b);
  EXPECT_EQ(p->s, "some text");
  EXPECT_EQ(p->color, Color::blue);
  EXPECT_EQ(p->vi, (std::vector<int>{4, 5, -6}));
  EXPECT_EQ(p->vd, (std::vector<double>{0.5, 1.5}));
  EXPECT_EQ(p->vs, (std::vector<std::string>{"x", "y z", ""}));
  EXPECT_EQ(*tree.blackboard().get<int>("oi"), -84);
  EXPECT_EQ(*tree.blackboard().get<std::string>("os"), "some text!");
}

TEST_F(Ports, DefaultsApplyWhenAttributesAreOmitted) {
  auto tree = load_main(R"(<Probe name="P" out_i="{oi}" out_s="{os}"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  Probe* p = find_probe(tree, "MainTree/P");
  EXPECT_EQ(p->i, 7);
  EXPECT_DOUBLE_EQ(p->d, 0.5);
  EXPECT_FALSE(p->b);
  EXPECT_EQ(p->s, "hello");
  EXPECT_EQ(p->color, Color::green);
  EXPECT_EQ(p->vi, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(p->vd.empty());
  EXPECT_EQ(p->vs, (std::vector<std::string>{"a", "b"}));
  EXPECT_TRUE(p->port("i")->from_default);
}

TEST_F(Ports, EnumAcceptsItsIntegerValue) {
  auto tree = load_main(R"(<Probe name="P" color="7" out_i="{oi}" out_s="{os}"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(find_probe(tree, "MainTree/P")->color, Color::blue);
}

TEST_F(Ports, BoolSpellings) {
  for (const char* t : {"true", "True", "TRUE", "1"}) EXPECT_TRUE(*convert_from_string<bool>(t)) << t;
  for (const char* f : {"false", "False", "FALSE", "0"}) EXPECT_FALSE(*convert_from_string<bool>(f)) << f;
  EXPECT_FALSE(convert_from_string<bool>("yes please").ok());
}

TEST_F(Ports, NumberConversionEdgeCases) {
  EXPECT_EQ(*convert_from_string<int>(" 12 "), 12);
  EXPECT_EQ(*convert_from_string<int>("+3"), 3);
  EXPECT_FALSE(convert_from_string<int>("1.5").ok());
  EXPECT_FALSE(convert_from_string<int>("99999999999").ok());
  EXPECT_FALSE(convert_from_string<int>("").ok());
  EXPECT_DOUBLE_EQ(*convert_from_string<double>("1e-3"), 1e-3);
  EXPECT_FALSE(convert_from_string<double>("nan").ok());
  EXPECT_FALSE(convert_from_string<double>("1.2.3").ok());
  auto list = convert_from_string<std::vector<double>>("1;x");
  EXPECT_TRUE(fails_with(list, ErrorCode::invalid_value));
  EXPECT_NE(list.error().message.find("'x'"), std::string::npos);  // content: the bad element is named
}

TEST_F(Ports, BadLiteralsAreValidationErrorsWithLineAndPath) {
  const auto d = validate(main_tree(R"(<Sequence>
  <Probe name="P1" i="abc"/>
  <Probe name="P2" d="1.2.3" b="maybe"/>
  <Probe name="P3" color="purple" vi="1;x" i="99999999999"/>
</Sequence>)"));
  ASSERT_EQ(d.size(), 6u) << visnav::bt::to_string(d);
  EXPECT_EQ(d[0].line, 4);
  EXPECT_EQ(d[0].node_path, "MainTree/Sequence[0]/P1");
  EXPECT_EQ(d[0].code, visnav::ErrorCode::invalid_value) << d[0].str();
  EXPECT_NE(d[0].message.find("port 'i'"), std::string::npos) << d[0].str();  // which port of the node
  EXPECT_EQ(d[1].line, 5);
  EXPECT_EQ(d[2].line, 5);
  EXPECT_TRUE(any_contains(d, "<string>:5: MainTree/Sequence[0]/P2: port 'b'"));
  EXPECT_TRUE(any_contains(d, "'purple' is not a value of enum Color (one of: red, green, blue)"));
  EXPECT_TRUE(any_contains(d, "port 'vi': bad value for type std::vector<int>"));
  EXPECT_TRUE(any_contains(d, "out of the int range"));
}

TEST_F(Ports, OutputPortGivenALiteralIsAnError) {
  const auto d = validate(main_tree(R"(<Probe out_i="42"/>)"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, visnav::ErrorCode::invalid_value) << d[0].str();
  EXPECT_EQ(d[0].line, 3) << d[0].str();
  EXPECT_EQ(d[0].node_path, "MainTree/Probe[0]");
}

TEST_F(Ports, EmptyBlackboardReferenceIsAnError) {
  const auto d = validate(main_tree(R"(<Probe i="{}" out_i="{ }"/>)"));
  ASSERT_EQ(d.size(), 2u) << visnav::bt::to_string(d);
  EXPECT_TRUE(any_contains(d, "empty blackboard reference"));
}

TEST_F(Ports, BlackboardReferencesAreReadAndConverted) {
  // One key per port type (a key used as int and double is a validation error, see
  // TypedBlackboard); values set by the host with another type are converted when read.
  auto tree = load_main(R"(<Probe name="P" i="{n}" d="{m}" s="{t}" vi="{list}" out_i="{oi}" out_s="{os}"/>)");
  tree.blackboard().set("n", 5);
  tree.blackboard().set("m", 5);
  tree.blackboard().set("t", 5);
  tree.blackboard().set("list", std::vector<int>{9, 8});
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  Probe* p = find_probe(tree, "MainTree/P");
  EXPECT_EQ(p->i, 5);
  EXPECT_DOUBLE_EQ(p->d, 5.0);  // int -> double
  EXPECT_EQ(p->s, "5");         // int -> string
  EXPECT_EQ(p->vi, (std::vector<int>{9, 8}));
  // A string entry is parsed with the port type, and the new value is seen on the next tick.
  tree.blackboard().set("n", std::string("12"));
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(p->i, 12);
}

TEST_F(Ports, MissingBlackboardEntryNamesNodeAndKey) {
  auto tree = load_main(R"(<Probe name="P" i="{missing}" out_i="{oi}" out_s="{os}"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  Probe* p = find_probe(tree, "MainTree/P");
  ASSERT_EQ(p->errors.size(), 1u);
  EXPECT_EQ(p->errors[0], "MainTree/P: port 'i' blackboard key 'missing' is not set");
}

TEST_F(Ports, WrongTypedBlackboardEntryIsAnError) {
  auto tree = load_main(R"(<Probe name="P" i="{x}" out_i="{oi}" out_s="{os}"/>)");
  tree.blackboard().set("x", std::string("not a number"));
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  Probe* p = find_probe(tree, "MainTree/P");
  ASSERT_EQ(p->errors.size(), 1u);
  EXPECT_NE(p->errors[0].find("'not a number' is not an integer"), std::string::npos);
  tree.blackboard().set("x", 2.5);  // non-integral double
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_NE(p->errors[0].find("holds a value of type double, not int"), std::string::npos);
}

TEST_F(Ports, UnconnectedOutputPortIsAnErrorAtRuntime) {
  auto tree = load_main(R"(<Probe name="P" out_i="{oi}"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  Probe* p = find_probe(tree, "MainTree/P");
  ASSERT_EQ(p->errors.size(), 1u);
  EXPECT_EQ(p->errors[0], "MainTree/P: port 'out_s' is not connected to a blackboard entry");
}

TEST_F(Ports, EqualsShorthandUsesThePortName) {
  auto tree = load_main(R"(<Probe name="P" i="{=}" out_i="{=}" out_s="{=}"/>)");
  tree.blackboard().set("i", 4);
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("out_i"), 8);
  EXPECT_EQ(*tree.blackboard().get<std::string>("out_s"), "hello!");
}

TEST_F(Ports, UndeclaredPortAccessIsAnError) {
  class Odd final : public visnav::bt::SyncActionNode {
   public:
    using SyncActionNode::SyncActionNode;
    static PortsList provided_ports() { return {}; }
    std::string error;

   protected:
    NodeStatus tick() override {
      auto v = get_input<int>("nope");
      if (!v) error = v.error().message;
      return NodeStatus::success;
    }
  };
  ASSERT_TRUE(registry.register_node<Odd>("Odd").ok());
  auto tree = load_main(R"(<Odd/>)");
  tree.tick_once();
  EXPECT_EQ(dynamic_cast<Odd&>(tree.root()).error, "MainTree/Odd[0]: port 'nope' is not a declared port of Odd");
}

// ---- blackboard --------------------------------------------------------------------------------

TEST(Blackboard, TypedValuesAndConversions) {
  auto bb = Blackboard::create();
  bb->set("i", 3);
  bb->set("s", "4.5");
  bb->set("b", true);
  EXPECT_EQ(*bb->get<int>("i"), 3);
  EXPECT_DOUBLE_EQ(*bb->get<double>("i"), 3.0);
  EXPECT_DOUBLE_EQ(*bb->get<double>("s"), 4.5);
  EXPECT_EQ(*bb->get<std::string>("b"), "true");
  EXPECT_FALSE(bb->get<int>("s").ok());
  EXPECT_FALSE(bb->get<int>("nothing").ok());
  EXPECT_EQ(bb->keys(), (std::vector<std::string>{"b", "i", "s"}));
  const auto* e = bb->find_entry("i");
  const auto seq = e->sequence;
  bb->set("i", 4);
  EXPECT_EQ(bb->find_entry("i"), e);  // entries are stable
  EXPECT_EQ(e->sequence, seq + 1);
}

TEST(Blackboard, RemappingAutoRemappingAndRoot) {
  auto root = Blackboard::create();
  auto mid = Blackboard::create(root);
  auto leaf = Blackboard::create(mid);
  mid->add_subtree_remapping("goal", "target");
  leaf->enable_auto_remapping(true);
  leaf->set("goal", 1);  // leaf -> (auto) mid.goal -> (remap) root.target
  EXPECT_EQ(*root->get<int>("target"), 1);
  EXPECT_FALSE(root->has("goal"));
  leaf->set("_private", 2);  // private keys stay local
  EXPECT_FALSE(mid->has("_private"));
  EXPECT_TRUE(leaf->has("_private"));
  mid->set("local", 3);  // no auto-remapping in mid: stays in mid
  EXPECT_FALSE(root->has("local"));
  leaf->set("@global", 4);
  EXPECT_EQ(*root->get<int>("global"), 4);
  EXPECT_EQ(*mid->get<int>("@global"), 4);
  EXPECT_EQ(&leaf->root(), root.get());
}

// ---- registry ----------------------------------------------------------------------------------

TEST_F(Ports, RegisteringAnIdTwiceIsAnError) {
  auto s = registry.register_node<TestAction>(
      "Act", "dup", [this](const std::string& n, const NodeConfig& c) { return std::make_unique<TestAction>(n, c, world); });
  EXPECT_TRUE(fails_with(s, ErrorCode::inconsistent, key_only("Act")));
  visnav::bt::NodeRegistry fresh;
  ASSERT_TRUE(visnav::bt::register_builtin_nodes(fresh).ok());
  EXPECT_FALSE(visnav::bt::register_builtin_nodes(fresh).ok());
}

struct BadDefault final : visnav::bt::SyncActionNode {
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {visnav::bt::input_port<double>("speed_mps", "fast", "speed")}; }
  NodeStatus tick() override { return NodeStatus::success; }
};
struct ReservedPort final : visnav::bt::SyncActionNode {
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {visnav::bt::input_port<int>("name")}; }
  NodeStatus tick() override { return NodeStatus::success; }
};
struct DuplicatePort final : visnav::bt::SyncActionNode {
  using SyncActionNode::SyncActionNode;
  static PortsList provided_ports() { return {visnav::bt::input_port<int>("a"), visnav::bt::output_port<int>("a")}; }
  NodeStatus tick() override { return NodeStatus::success; }
};

TEST_F(Ports, InvalidPortDeclarationsAreRejectedAtRegistration) {
  auto s1 = registry.register_node<BadDefault>("BadDefault");
  EXPECT_TRUE(fails_with(s1, ErrorCode::invalid_value, key_only("speed_mps")));
  EXPECT_FALSE(registry.register_node<ReservedPort>("ReservedPort").ok());
  EXPECT_FALSE(registry.register_node<DuplicatePort>("DuplicatePort").ok());
  EXPECT_FALSE(registry.register_node<BadDefault>("has space").ok());
  EXPECT_EQ(registry.find("BadDefault"), nullptr);
}

TEST_F(Ports, EnumRegistrationRules) {
  enum class Other { x = 5 };
  EXPECT_FALSE(registry.register_enum<Color>("Color", {{"red", Color::red}}).ok());  // same type twice
  EXPECT_FALSE(registry.register_enum<Other>("Other", {{"red", Other::x}}).ok());    // 'red' is 1 in Color
  EXPECT_TRUE(registry.register_enum<Other>("Other", {{"x", Other::x}}).ok());
  EXPECT_EQ(registry.enums()->lookup("x"), 5);
}

TEST_F(Ports, ThrowingFactoryBecomesALoadError) {
  struct Boom final : visnav::bt::SyncActionNode {
    using SyncActionNode::SyncActionNode;
    NodeStatus tick() override { return NodeStatus::success; }
  };
  ASSERT_TRUE(registry
                  .register_node<Boom>("Boom", "throws",
                                       [](const std::string&, const NodeConfig&) -> std::unique_ptr<Boom> {
                                         throw std::runtime_error("no camera");
                                       })
                  .ok());
  auto tree = visnav::bt::load_tree_string(main_tree("<Boom/>"), registry, options);
  ASSERT_FALSE(tree.ok());
  // Content: the factory's own words reach the user, after the place that raised them.
  EXPECT_EQ(tree.error().message, "<string>:3: MainTree/Boom[0]: node factory threw an exception: no camera");
}

}  // namespace
}  // namespace bt_test
