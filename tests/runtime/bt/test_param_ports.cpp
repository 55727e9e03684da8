// Ports generated from a params schema (visnav/bt/param_ports.hpp): types and struct defaults,
// the literal check of a declared range, and reading the values back into the validated struct.
#include <typeindex>

#include "error_expect.hpp"
#include "bt_test_support.hpp"
#include "visnav/bt/param_ports.hpp"

namespace bt_test {
namespace {

using visnav::ErrorCode;
using visnav::Result;
using visnav::bt::NodeStatus;
using visnav::bt::PortInfo;
using visnav::test::fails_with;
using visnav::test::key_only;

struct TestParams {
  int frames = 3;
  double gain = 0.25;
  bool upright = false;
  std::string mode = "fast";
  std::vector<double> weights_m = {1.0, 2.5};
  std::vector<std::string> tags = {"a", "b"};
  double min_m = 0.5;
  double max_m = 2.0;

  [[nodiscard]] visnav::Status validate() const {
    VISNAV_TRY(schema().check(*this));
    if (min_m > max_m) return visnav::fail(ErrorCode::inconsistent, "min_m must not exceed max_m");
    return visnav::ok();
  }
  static const visnav::ParamSchema<TestParams>& schema() {
    using P = TestParams;
    static const auto s = visnav::ParamSchema<P>{}
                              .field("frames", &P::frames, "frames to take")
                              .range(1, 10)
                              .field("gain", &P::gain, "steering gain")
                              .range(0.0, 1.0)
                              .field("upright", &P::upright, "skip orientation")
                              .field("mode", &P::mode, "speed mode")
                              .one_of({"fast", "slow"})
                              .field("weights_m", &P::weights_m, "weights, m")
                              .field("tags", &P::tags, "tags")
                              .field("min_m", &P::min_m, "lower bound, m")
                              .field("max_m", &P::max_m, "upper bound, m");
    return s;
  }
};

/// Ports: a few of its own plus TestParams'; tick() reads them back with the SDK helpers.
class ParamNode final : public visnav::bt::SyncActionNode {
 public:
  ParamNode(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) {}
  static PortsList provided_ports() {
    PortsList p = {visnav::bt::input_port<std::string>("label", "x", "not a parameter")};
    visnav::bt::append_param_ports(p, TestParams::schema());
    return p;
  }

  std::optional<Result<visnav::ConfigNode>> read;
  std::optional<Result<TestParams>> parsed;

 protected:
  NodeStatus tick() override {
    read = visnav::bt::read_param_ports(*this, TestParams::schema().docs());
    parsed = visnav::bt::parse_param_ports(*this, TestParams::schema());
    return *parsed ? NodeStatus::success : NodeStatus::failure;
  }
};

/// One group port `params` for TestParams with tuned defaults (gain 0.5, frames 4): tick()
/// parses it with parse_param_group.
class GroupNode final : public visnav::bt::SyncActionNode {
 public:
  GroupNode(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) {}
  static const TestParams& tuned() {
    static const TestParams t = [] {
      TestParams p;
      p.gain = 0.5;
      p.frames = 4;
      return p;
    }();
    return t;
  }
  static PortsList provided_ports() {
    return {visnav::bt::param_group_port("params", TestParams::schema(), tuned(), "The test mechanism.")};
  }

  std::optional<Result<TestParams>> parsed;

 protected:
  NodeStatus tick() override {
    parsed = visnav::bt::parse_param_group(*this, "params", TestParams::schema(), tuned());
    return *parsed ? NodeStatus::success : NodeStatus::failure;
  }
};

class ParamPorts : public BtTest {
 protected:
  ParamPorts() {
    EXPECT_TRUE(registry.register_node<ParamNode>("ParamNode", "params schema ports").ok());
    EXPECT_TRUE(registry.register_node<GroupNode>("GroupNode", "one group port").ok());
  }

  ParamNode* node(visnav::bt::Tree& tree) { return dynamic_cast<ParamNode*>(tree.find_node("MainTree/N")); }
};

const PortInfo* find_port(const PortsList& ports, const std::string& name) {
  for (const PortInfo& p : ports)
    if (p.name == name) return &p;
  return nullptr;
}

TEST_F(ParamPorts, GeneratedPortsCarryTheStructDefaultsAndTypes) {
  const PortsList ports = ParamNode::provided_ports();
  ASSERT_EQ(ports.size(), 9U);
  EXPECT_EQ(ports[0].name, "label");  // the node's own ports first, then the schema's in order
  const std::vector<std::string> names = {"frames", "gain", "upright", "mode", "weights_m", "tags", "min_m", "max_m"};
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(ports[i + 1].name, names[i]);
    EXPECT_EQ(ports[i + 1].direction, visnav::bt::PortDirection::input);
  }

  struct Expected {
    std::string name;
    std::type_index type;
    std::string default_value;
    std::string description;
    std::string constraint;
  };
  const std::vector<Expected> expected = {
      {"frames", typeid(int), "3", "frames to take [1, 10]", "[1, 10]"},
      {"gain", typeid(double), "0.25", "steering gain [0, 1]", "[0, 1]"},
      {"upright", typeid(bool), "false", "skip orientation", ""},
      {"mode", typeid(std::string), "fast", "speed mode one of: fast slow", "one of: fast slow"},
      {"weights_m", typeid(std::vector<double>), "1;2.5", "weights, m", ""},
      {"tags", typeid(std::vector<std::string>), "a;b", "tags", ""},
  };
  for (const Expected& e : expected) {
    SCOPED_TRACE(e.name);
    const PortInfo* p = find_port(ports, e.name);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->type, e.type);
    ASSERT_TRUE(p->default_value.has_value());
    EXPECT_EQ(*p->default_value, e.default_value);
    EXPECT_EQ(p->description, e.description);
    EXPECT_EQ(p->constraint, e.constraint);
    EXPECT_TRUE(static_cast<bool>(p->check));
    EXPECT_TRUE(p->check(e.default_value).ok()) << "the default passes its own check";
  }

  // The defaults, as the ports give them without any attribute, parse back to the struct's.
  auto tree = load_main(R"(<ParamNode name="N"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  ASSERT_TRUE(node(tree)->parsed.has_value());
  const TestParams& got = **node(tree)->parsed;
  const TestParams defaults;
  EXPECT_EQ(got.frames, defaults.frames);
  EXPECT_DOUBLE_EQ(got.gain, defaults.gain);
  EXPECT_EQ(got.upright, defaults.upright);
  EXPECT_EQ(got.mode, defaults.mode);
  EXPECT_EQ(got.weights_m, defaults.weights_m);
  EXPECT_EQ(got.tags, defaults.tags);
}

TEST_F(ParamPorts, UnsupportedTypeIsAnErrorNamingTheParameter) {
  visnav::bt::ParamPorts params;
  params.docs.push_back(visnav::ParamDoc{"pose", "pose2d", "0;0;0", "a pose", ""});
  params.check = [](std::string_view, const visnav::ConfigNode&) { return visnav::ok(); };
  PortsList ports;
  auto st = visnav::bt::append_param_ports(ports, params);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("'pose'"), std::string::npos) << st.error().message;
  EXPECT_TRUE(ports.empty());
}

TEST_F(ParamPorts, LiteralOutsideADeclaredRangeIsRefusedByThePortsCheck) {
  const PortsList ports = ParamNode::provided_ports();
  const PortInfo* frames = find_port(ports, "frames");
  ASSERT_NE(frames, nullptr);
  EXPECT_TRUE(frames->check("10").ok());
  auto refused = frames->check("11");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::out_of_range);
  EXPECT_NE(refused.error().message.find("out of range [1, 10]"), std::string::npos) << refused.error().message;
  EXPECT_FALSE(find_port(ports, "mode")->check("medium").ok());

  // Before the first tick: validation (and so loading) names the element's line and the key.
  auto d = validate(main_tree(R"(<ParamNode name="N" frames="11"/>)"));
  ASSERT_EQ(d.size(), 1U);
  EXPECT_EQ(d[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(d[0].line, 3);
  EXPECT_NE(d[0].message.find("port 'frames'"), std::string::npos) << d[0].str();
  EXPECT_NE(d[0].message.find("out of range [1, 10]"), std::string::npos) << d[0].str();
  EXPECT_FALSE(visnav::bt::load_tree_string(main_tree(R"(<ParamNode name="N" frames="11"/>)"), registry, options).ok());
  EXPECT_TRUE(validate(main_tree(R"(<ParamNode name="N" frames="10"/>)")).empty());
}

TEST_F(ParamPorts, ReadBackGivesTheValuesSetAndParseValidates) {
  auto tree = load_main(
      R"(<ParamNode name="N" frames="7" gain="{g}" upright="true" mode="slow" weights_m="{w}" tags="x;y z" min_m="1.5"/>)");
  tree.blackboard().set<double>("g", 0.125);
  tree.blackboard().set<std::vector<double>>("w", {0.1, 3.0});
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  ParamNode* n = node(tree);
  ASSERT_NE(n, nullptr);

  ASSERT_TRUE(n->read.has_value() && n->read->ok());
  const visnav::ConfigNode& map = **n->read;
  ASSERT_TRUE(map.is_map());
  EXPECT_EQ(map.where().line, 3);  // located at the element
  auto text = [&map](const char* key) {
    const visnav::ConfigNode* v = map.find(key);
    return v != nullptr && v->is_scalar() ? v->scalar() : std::string("<missing>");
  };
  EXPECT_EQ(text("frames"), "7");  // literals as written
  EXPECT_EQ(text("tags"), "x;y z");
  EXPECT_EQ(text("gain"), "0.125");
  EXPECT_EQ(text("weights_m"), "0.10000000000000001;3");  // blackboard values in full precision
  EXPECT_EQ(text("max_m"), "2");  // the default

  ASSERT_TRUE(n->parsed.has_value() && n->parsed->ok());
  const TestParams& p = **n->parsed;
  EXPECT_EQ(p.frames, 7);
  EXPECT_DOUBLE_EQ(p.gain, 0.125);
  EXPECT_TRUE(p.upright);
  EXPECT_EQ(p.mode, "slow");
  ASSERT_EQ(p.weights_m.size(), 2U);
  EXPECT_DOUBLE_EQ(p.weights_m[0], 0.1);
  EXPECT_DOUBLE_EQ(p.weights_m[1], 3.0);
  EXPECT_EQ(p.tags, (std::vector<std::string>{"x", "y z"}));
  EXPECT_DOUBLE_EQ(p.min_m, 1.5);
  EXPECT_DOUBLE_EQ(p.max_m, 2.0);

  // A blackboard value is not checked at load: parse() refuses it at the tick, naming the key.
  tree.blackboard().set<double>("g", 1.5);
  ASSERT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_TRUE(fails_with(*n->parsed, ErrorCode::out_of_range, key_only("gain")));
}

TEST_F(ParamPorts, ParseRunsTheStructsValidate) {
  // Each literal is in range, so the tree loads; the cross-field rule is validate()'s.
  auto tree = load_main(R"(<ParamNode name="N" min_m="3" max_m="2"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::failure);
  ParamNode* n = node(tree);
  ASSERT_NE(n, nullptr);
  ASSERT_TRUE(n->parsed.has_value());
  EXPECT_TRUE(fails_with(*n->parsed, ErrorCode::inconsistent));
  EXPECT_NE(n->parsed->error().message.find("min_m must not exceed max_m"), std::string::npos)
      << n->parsed->error().message;
}

TEST_F(ParamPorts, AnUnsetBlackboardEntryIsAnErrorNamingThePort) {
  auto tree = load_main(R"(<ParamNode name="N" gain="{nowhere}"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::failure);
  ParamNode* n = node(tree);
  ASSERT_NE(n, nullptr);
  ASSERT_TRUE(n->read.has_value());
  ASSERT_FALSE(n->read->ok());
  EXPECT_NE(n->read->error().message.find("gain"), std::string::npos) << n->read->error().message;
}

TEST_F(ParamPorts, AGroupPortSetsSomeKeysOnTopOfTheNodesDefaults) {
  const PortsList ports = GroupNode::provided_ports();
  ASSERT_EQ(ports.size(), 1U);
  EXPECT_EQ(ports[0].type, typeid(std::string));
  ASSERT_TRUE(ports[0].default_value.has_value());
  EXPECT_EQ(*ports[0].default_value, "");
  // The description documents every key with the node's default, not the struct's.
  EXPECT_NE(ports[0].description.find("The test mechanism. Keys: frames (int, default 4, [1, 10]): frames to take"),
            std::string::npos)
      << ports[0].description;
  EXPECT_NE(ports[0].description.find("gain (double, default 0.5, [0, 1])"), std::string::npos) << ports[0].description;

  auto tree = load_main(R"(<GroupNode name="N" params=" frames = 7 ; mode=slow; tags=x;"/>)");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  auto* n = dynamic_cast<GroupNode*>(tree.find_node("MainTree/N"));
  ASSERT_NE(n, nullptr);
  ASSERT_TRUE(n->parsed.has_value() && n->parsed->ok());
  EXPECT_EQ((*n->parsed)->frames, 7);
  EXPECT_EQ((*n->parsed)->mode, "slow");
  EXPECT_EQ((*n->parsed)->tags, (std::vector<std::string>{"x"}));
  EXPECT_DOUBLE_EQ((*n->parsed)->gain, 0.5);  // unset: the node's default

  auto empty = load_main(R"(<GroupNode name="N"/>)");
  ASSERT_EQ(empty.tick_once(), NodeStatus::success);
  auto* e = dynamic_cast<GroupNode*>(empty.find_node("MainTree/N"));
  ASSERT_NE(e, nullptr);
  EXPECT_EQ((*e->parsed)->frames, 4);
  EXPECT_DOUBLE_EQ((*e->parsed)->gain, 0.5);
}

TEST_F(ParamPorts, AGroupPortsBadLiteralIsRefusedAtItsLineNamingThePortAndKey) {
  struct Case {
    std::string text;
    ErrorCode code;
    std::string says;
  };
  const std::vector<Case> bad = {
      {"frames=11", ErrorCode::out_of_range, "port 'params': key 'frames': value 11 is out of range [1, 10]"},
      {"fram=3", ErrorCode::unknown_key, "unknown key 'fram' (known keys: frames, gain"},
      {"frames=3; frames=4", ErrorCode::invalid_value, "key 'frames' is given twice"},
      {"frames", ErrorCode::invalid_value, "entry 'frames' is not key=value"},
      {"=3", ErrorCode::invalid_value, "has no key"},
      {"mode=medium", ErrorCode::out_of_range, "key 'mode': value 'medium' is not one of: fast slow"},
      {"min_m=3", ErrorCode::inconsistent, "min_m must not exceed max_m"},  // validate() on top of the defaults
  };
  for (const Case& k : bad) {
    SCOPED_TRACE(k.text);
    const std::string xml = main_tree(R"(<GroupNode name="N" params=")" + k.text + R"("/>)");
    auto d = validate(xml);
    ASSERT_EQ(d.size(), 1U);
    EXPECT_EQ(d[0].code, k.code) << d[0].str();
    EXPECT_EQ(d[0].line, 3);
    EXPECT_NE(d[0].message.find("port 'params'"), std::string::npos) << d[0].str();
    EXPECT_NE(d[0].message.find(k.says), std::string::npos) << d[0].str();
    EXPECT_FALSE(visnav::bt::load_tree_string(xml, registry, options).ok());
  }
  // min_m=1.5 is fine with max_m's default 2; with max_m=1 it is not.
  EXPECT_TRUE(validate(main_tree(R"(<GroupNode name="N" params="min_m=1.5"/>)")).empty());
  EXPECT_EQ(validate(main_tree(R"(<GroupNode name="N" params="min_m=1.5; max_m=1"/>)")).size(), 1U);
}

TEST_F(ParamPorts, AGroupPortFromTheBlackboardIsParsedAtTheTick) {
  auto tree = load_main(R"(<GroupNode name="N" params="{p}"/>)");
  tree.blackboard().set<std::string>("p", "gain=0.75");
  ASSERT_EQ(tree.tick_once(), NodeStatus::success);
  auto* n = dynamic_cast<GroupNode*>(tree.find_node("MainTree/N"));
  ASSERT_NE(n, nullptr);
  EXPECT_DOUBLE_EQ((*n->parsed)->gain, 0.75);
  tree.blackboard().set<std::string>("p", "gain=2");
  ASSERT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_TRUE(fails_with(*n->parsed, ErrorCode::out_of_range, key_only("gain")));
  EXPECT_NE(n->parsed->error().message.find("port 'params'"), std::string::npos) << n->parsed->error().message;
}

}  // namespace
}  // namespace bt_test
