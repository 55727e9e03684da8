// The runtime's primitive adapter (visnav/primitive.hpp): ports generated from a ParamSchema and
// checked before the first tick, the edge protocol, the one send-failure and no-new-frame policy,
// the failure codes (`failure_code`) and the teacher's stored edge — on a minimal in-process
// primitive and a kinematic fake robot.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "fake_devices.hpp"
#include "visnav/primitive.hpp"

namespace fs = std::filesystem;
using visnav::bt::NodeStatus;

namespace visnav {
using visnav::ErrorCode;

namespace {

struct CoreParams {  // stands for a primitive core's own params, with its own schema
  double gain = 0.5;
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<CoreParams>& schema() {
    static const auto s = ParamSchema<CoreParams>{}.field("gain", &CoreParams::gain, "core gain").range(0.0, 1.0);
    return s;
  }
};

struct TestParams {
  double speed_mps = 0.5;
  CoreParams core;
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<TestParams>& schema() {
    static const auto s = ParamSchema<TestParams>{}
                              .field("speed_mps", &TestParams::speed_mps, "forward speed")
                              .range(0.1, 1.0)
                              .include(&TestParams::core, CoreParams::schema(), {{"gain", "core_gain"}});
    return s;
  }
};

/// Drives straight at speed_mps, always confident; payload: one byte, 7. It sees itself kAheadMm
/// farther along than odometry says (a visual along-track correction, as FollowPathEdge's
/// thumbnails give; 0 for TestReplayer).
template <int kAheadMm>
class DrivingReplayer final : public EdgeReplayer {
 public:
  static constexpr double kAheadM = kAheadMm / 1000.0;
  using Params = TestParams;
  static constexpr bool kUsesDetector = false;
  explicit DrivingReplayer(const Params& p) : p_(p) {}
  Status begin(const ReplayStart& s) override {
    if (s.payload.size() != 1 || s.payload[0] != 7) return fail("not a test payload");
    length_m_ = s.edge.length_m;
    return ok();
  }
  ReplayStep step(const ReplayInput& in) override {
    ReplayStep out;
    out.distance_m = in.edge_distance_m + kAheadM;
    out.finished = out.distance_m >= length_m_;
    out.confidence = 1.0;
    out.command = out.finished ? Twist{} : Twist{p_.speed_mps, 0.0};
    out.status = "testing";
    return out;
  }

 private:
  Params p_;
  double length_m_ = 0.0;
};
using TestReplayer = DrivingReplayer<0>;
using AheadReplayer = DrivingReplayer<300>;

/// Drives straight at speed_mps and never finishes. kBlind: never confident (the lost policy
/// decides); kLosesView, kGivesUp: confident, and past 0.15 m fails itself with a
/// ReplayStep::failure, with the code view_lost or without a code.
enum class Fault : std::uint8_t { kBlind, kLosesView, kGivesUp };
template <Fault kFault>
class FaultyReplayer final : public EdgeReplayer {
 public:
  using Params = TestParams;
  static constexpr bool kUsesDetector = false;
  explicit FaultyReplayer(const Params& p) : p_(p) {}
  Status begin(const ReplayStart&) override { return ok(); }
  ReplayStep step(const ReplayInput& in) override {
    ReplayStep out;
    out.distance_m = in.edge_distance_m;
    out.command = Twist{p_.speed_mps, 0.0};
    out.confidence = kFault == Fault::kBlind ? 0.0 : 1.0;
    if (kFault != Fault::kBlind && in.edge_distance_m > 0.15) {
      out.failure = "lost the test view";
      if (kFault == Fault::kLosesView) out.failure_code = replay_failure::view_lost;
    }
    return out;
  }

 private:
  Params p_;
};

class TestTeacher final : public EdgeTeacher {
 public:
  using Params = TestParams;
  static constexpr bool kUsesDetector = false;
  explicit TestTeacher(const Params&) {}
  Status begin(const TeachStart&) override { return ok(); }
  Status step(const TeachInput& in) override {
    frames_ += in.frame != nullptr ? 1 : 0;
    return ok();
  }
  Result<TaughtEdge> finish(const TeachInput&) override { return TaughtEdge{"test", {7}, {{"test_frames", frames_}}}; }

 private:
  double frames_ = 0;
};

class FailingRobot final : public Robot {
 public:
  explicit FailingRobot(test::KinematicRobot& inner) : inner_(inner) {}
  Status send_command(const Twist& c) override {
    if (c.linear_mps != 0.0) return fail("link down");
    return inner_.send_command(c);
  }
  std::optional<Odometry> latest_odometry() override { return inner_.latest_odometry(); }

 private:
  test::KinematicRobot& inner_;
};

class CaptureLogger final : public Logger {
 public:
  void log(LogLevel, std::string_view component, std::string_view message) override {
    text += std::string(component) + ": " + std::string(message) + "\n";
  }
  std::string text;
};

class PrimitiveAdapter : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_test_dir("visnav_adapter");
    ASSERT_TRUE(test::attach_scratch_map(host_, bus_, robot_, map_, dir_));
    ASSERT_TRUE(bt::register_builtin_nodes(registry_).ok());
    ASSERT_TRUE(register_replayer<TestReplayer>(registry_, host_, "ReplayTestEdge", "test", {"test"}).ok());
    ASSERT_TRUE(register_teacher<TestTeacher>(registry_, host_, "TeachTestEdge", "test", {"test"}).ok());
    ASSERT_TRUE(register_replayer<AheadReplayer>(registry_, host_, "ReplayAheadEdge", "test", {"test"}).ok());
    using Blind = FaultyReplayer<Fault::kBlind>;
    using Losing = FaultyReplayer<Fault::kLosesView>;
    using GivingUp = FaultyReplayer<Fault::kGivesUp>;
    ASSERT_TRUE(register_replayer<Blind>(registry_, host_, "ReplayBlindEdge", "test", {"test"}).ok());
    ASSERT_TRUE(register_replayer<Losing>(registry_, host_, "ReplayLosingEdge", "test", {"test"}).ok());
    ASSERT_TRUE(register_replayer<GivingUp>(registry_, host_, "ReplayGivingUpEdge", "test", {"test"}).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string add_edge(std::vector<std::uint8_t> payload) {
    NodeRecord node;
    node.name = "a";
    auto a = map_->add_node(node);
    node.name = "b";
    auto b = map_->add_node(node);
    EdgeRecord edge;
    edge.from = *a;
    edge.to = *b;
    edge.kind = "test";
    edge.length_m = 1.0;
    auto id = map_->add_edge(edge, payload);
    EXPECT_TRUE(id.ok());
    return *id;
  }
  void publish_frame() {
    Frame f;
    f.sequence = ++sequence_;
    f.image = cv::Mat(4, 4, CV_8UC1, cv::Scalar(static_cast<double>(sequence_ % 200)));
    bus_.publish_frame(f);
  }
  /// A string entry of the tree's blackboard, "<unset>" when there is none.
  static std::string entry(const bt::Tree& tree, const std::string& key) {
    auto v = tree.blackboard().get<std::string>(key);
    return v ? *v : std::string("<unset>");
  }
  /// Ticks `tree` until it leaves RUNNING (at most `ticks` times).
  NodeStatus run(bt::Tree& tree, int ticks = 100) {
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < ticks && s == NodeStatus::running; ++i) s = tick(tree);
    return s;
  }
  NodeStatus tick(bt::Tree& tree, bool new_frame = true) {
    if (new_frame) publish_frame();
    const NodeStatus s = tree.tick_once();
    robot_.step(0.1);
    clock_.advance(0.1);
    return s;
  }

  fs::path dir_;
  PluginLoader loader_{std::vector<std::string>{}};
  CaptureLogger logger_;
  ManualClock clock_;
  RuntimeHost host_{loader_, logger_, clock_};
  bt::NodeRegistry registry_;
  FrameBus bus_;
  test::KinematicRobot robot_{bus_};
  std::optional<MapStore> map_;
  std::uint64_t sequence_ = 0;
};

TEST_F(PrimitiveAdapter, PortsComeFromTheSchemaWithItsDefaultsAndConstraints) {
  const bt::NodeManifest* m = registry_.find("ReplayTestEdge");
  ASSERT_NE(m, nullptr);
  const bt::PortInfo* speed = m->find_port("speed_mps");
  ASSERT_NE(speed, nullptr);
  EXPECT_EQ(speed->default_value, "0.5");
  EXPECT_EQ(speed->constraint, "[0.1, 1]");
  const bt::PortInfo* gain = m->find_port("core_gain");  // renamed field of the nested core params
  ASSERT_NE(gain, nullptr);
  EXPECT_EQ(gain->default_value, "0.5");
  EXPECT_EQ(gain->constraint, "[0, 1]");
  for (const char* protocol : {"edge", "carried_m", "lap", "max_blind_m", "confident_at_m"})
    EXPECT_NE(m->find_port(protocol), nullptr) << protocol;
  for (const char* protocol : {"edge_from", "edge_to", "finish", "edge", "speed_mps"})
    EXPECT_NE(registry_.find("TeachTestEdge")->find_port(protocol), nullptr) << protocol;
}

TEST_F(PrimitiveAdapter, AnOutOfRangeLiteralFailsWhenTheTreeLoadsNotWhenTheRobotGetsThere) {
  const std::string xml = "<root BTCPP_format=\"4\"><BehaviorTree ID=\"Main\">\n<Sequence>\n"
                          "<ReplayTestEdge edge=\"e0\" speed_mps=\"9\"/>\n"
                          "<ReplayTestEdge edge=\"e1\" core_gain=\"2\"/>\n"
                          "<ReplayTestEdge edge=\"e2\" max_heading_deviation_deg=\"270\"/>\n</Sequence></BehaviorTree></root>";
  ASSERT_FALSE(bt::load_tree_string(xml, registry_, bt::LoadOptions{}).ok());
  // Each bad literal is its own diagnostic: code, line and node.
  const auto d = bt::validate_tree_string(xml, registry_, bt::LoadOptions{});
  ASSERT_EQ(d.size(), 3u) << bt::to_string(d);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(d[i].code, ErrorCode::out_of_range) << bt::to_string(d);
    EXPECT_EQ(d[i].line, 3 + i) << bt::to_string(d);
    EXPECT_EQ(d[i].node_path, "Main/Sequence[0]/ReplayTestEdge[" + std::to_string(i) + "]");
  }
  // speed_mps and core_gain come from the primitive's Params (core_gain through
  // ParamSchema::include); max_heading_deviation_deg is a lost-policy port, generated the same way.
}

TEST_F(PrimitiveAdapter, TeachesAnEdgeThatTheReplayerDrivesToItsEnd) {
  auto teach = test::load_main_tree("<TeachTestEdge edge_from=\"\" edge_to=\"\"/>", registry_, &clock_);
  robot_.command_ = Twist{0.5, 0.0};  // the operator drives; the teacher never commands
  for (int i = 0; i < 20; ++i) EXPECT_EQ(tick(teach), NodeStatus::running);
  teach.blackboard().set("finish_edge", true);
  EXPECT_EQ(tick(teach), NodeStatus::success) << logger_.text;
  const std::string id = *teach.blackboard().get<std::string>("taught_edge");
  const EdgeRecord* e = map_->find_edge(id);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->kind, "test");
  EXPECT_NEAR(e->length_m, 1.05, 0.06);
  EXPECT_EQ(e->statistics.at("test_frames"), 21.0);
  EXPECT_EQ(e->statistics.at("frames"), 21.0);
  EXPECT_EQ(e->statistics.at("image_width_px"), 4.0);

  robot_.odom_ = Odometry{};
  robot_.command_ = Twist{};
  robot_.publish();
  auto replay = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\"/>", registry_, &clock_);
  NodeStatus s = NodeStatus::running;
  for (int i = 0; i < 100 && s == NodeStatus::running; ++i) s = tick(replay);
  EXPECT_EQ(s, NodeStatus::success) << logger_.text;
  EXPECT_NEAR(robot_.odom_.distance_m, e->length_m, 0.06);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(PrimitiveAdapter, TheDistanceScaleMakesThePrimitiveCountTheEdgeInTaughtMetres) {
  // Odometry reads 1.25 m per taught metre: the 1 m edge ends after 1.25 m of odometry, and the
  // carried 0.2 m (taught metres) are 0.25 m of it. Out of [0.5, 2] is an error naming the port.
  const std::string id = add_edge({7});
  auto replay = [&](const std::string& attributes, std::optional<double> scale_entry = std::nullopt) {
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\" speed_mps=\"0.25\" " + attributes + "/>",
                                     registry_, &clock_);
    if (scale_entry) tree.blackboard().set("scale", *scale_entry);
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < 100 && s == NodeStatus::running; ++i) s = tick(tree);
    return s;
  };
  EXPECT_EQ(replay("distance_scale=\"1.25\""), NodeStatus::success) << logger_.text;
  EXPECT_NEAR(robot_.odom_.distance_m, 1.25, 0.026);
  EXPECT_EQ(replay("distance_scale=\"1.25\" carried_m=\"0.2\""), NodeStatus::success) << logger_.text;
  EXPECT_NEAR(robot_.odom_.distance_m, 1.0, 0.026);
  EXPECT_EQ(replay(""), NodeStatus::success) << logger_.text;  // unset: 1
  EXPECT_NEAR(robot_.odom_.distance_m, 1.0, 0.026);
  // A literal 3 is refused when the tree is loaded (ValidateTest.CrossPortRules...); a value
  // that reaches the node from the blackboard fails it before it moves.
  EXPECT_EQ(replay("distance_scale=\"{scale}\"", 3.0), NodeStatus::failure);
  EXPECT_NE(logger_.text.find("distance_scale"), std::string::npos) << logger_.text;
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
}

TEST_F(PrimitiveAdapter, TheAlongTrackCorrectionIsPublishedEveryFrameAndAtTheEnd) {
  // shift_m is what a decorator that restarts the node mid-edge (ReplayAvoiding) carries over;
  // end_shift_m what FollowRoute ends the edge with. Both are 0 for odometry alone.
  const std::string id = add_edge({7});
  auto tree = test::load_main_tree("<ReplayAheadEdge edge=\"" + id + "\" speed_mps=\"0.25\"/>", registry_, &clock_);
  tree.blackboard().set("edge_shift_m", 5.0);  // a previous edge's value is never seen
  EXPECT_EQ(tick(tree), NodeStatus::running) << logger_.text;
  EXPECT_NEAR(*tree.blackboard().get<double>("edge_shift_m"), AheadReplayer::kAheadM, 1e-9);
  NodeStatus s = NodeStatus::running;
  for (int i = 0; i < 100 && s == NodeStatus::running; ++i) s = tick(tree);
  EXPECT_EQ(s, NodeStatus::success) << logger_.text;
  EXPECT_NEAR(robot_.odom_.distance_m, 1.0 - AheadReplayer::kAheadM, 0.026);
  EXPECT_NEAR(*tree.blackboard().get<double>("edge_end_shift_m"), AheadReplayer::kAheadM, 1e-9);

  robot_.odom_ = Odometry{};
  robot_.publish();
  auto plain = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\" speed_mps=\"0.25\"/>", registry_, &clock_);
  plain.blackboard().set("edge_shift_m", 5.0);
  EXPECT_EQ(tick(plain), NodeStatus::running) << logger_.text;
  EXPECT_EQ(*plain.blackboard().get<double>("edge_shift_m"), 0.0);
}

TEST_F(PrimitiveAdapter, ABadPayloadFailsBeforeTheRobotMoves) {
  const std::string id = add_edge({1, 2});
  auto tree = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\"/>", registry_, &clock_);
  EXPECT_EQ(tick(tree), NodeStatus::failure);
  EXPECT_NE(logger_.text.find("edge " + id + " payload: not a test payload"), std::string::npos) << logger_.text;
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
  EXPECT_EQ(entry(tree, "edge_failure_code"), "bad_payload");
  auto unknown = test::load_main_tree("<ReplayTestEdge edge=\"no_such_edge\"/>", registry_, &clock_);
  EXPECT_EQ(tick(unknown), NodeStatus::failure);
  EXPECT_EQ(entry(unknown, "edge_failure_code"), "bad_edge");
}

TEST_F(PrimitiveAdapter, AFailedCommandFailsTheNodeAndStopsTheRobot) {
  FailingRobot failing(robot_);
  host_.set_robot(&failing);
  const std::string id = add_edge({7});
  auto tree = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\"/>", registry_, &clock_);
  EXPECT_EQ(tick(tree), NodeStatus::failure);
  EXPECT_NE(logger_.text.find("sending the command: link down"), std::string::npos) << logger_.text;
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(entry(tree, "edge_failure_code"), "command_failed");
}

TEST_F(PrimitiveAdapter, WithoutNewFramesTheLastCommandIsKeptOnlyWithinMaxFrozen) {
  const std::string id = add_edge({7});
  auto tree = test::load_main_tree("<ReplayTestEdge edge=\"" + id + "\" speed_mps=\"1\" max_frozen_m=\"0.35\"/>",
                                   registry_, &clock_);
  EXPECT_EQ(tick(tree), NodeStatus::running);
  const int sent = robot_.commands_;
  // 0.1 m per tick without a new frame: re-sent at 0.1, 0.2 and 0.3 m, refused beyond 0.35 m.
  for (int i = 0; i < 3; ++i) EXPECT_EQ(tick(tree, /*new_frame=*/false), NodeStatus::running) << i;
  EXPECT_EQ(robot_.commands_, sent + 3);
  EXPECT_EQ(robot_.command_.linear_mps, 1.0);
  EXPECT_EQ(tick(tree, /*new_frame=*/false), NodeStatus::failure);
  EXPECT_NE(logger_.text.find("camera frozen: no new frame over 0.400 m"), std::string::npos) << logger_.text;
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(entry(tree, "edge_failure_code"), "input_lost");
}

TEST_F(PrimitiveAdapter, AFrozenImageFailsAsInputLost) {
  // New frames with identical pixels while the robot travels: the lost policy's frozen camera.
  const std::string id = add_edge({7});
  auto tree = test::load_main_tree(
      "<ReplayTestEdge edge=\"" + id + "\" speed_mps=\"1\" max_frozen_m=\"0.35\"/>", registry_, &clock_);
  const cv::Mat same(4, 4, CV_8UC1, cv::Scalar(90.0));
  NodeStatus s = NodeStatus::running;
  for (int i = 0; i < 20 && s == NodeStatus::running; ++i) {
    Frame f;
    f.sequence = ++sequence_;
    f.image = same.clone();
    bus_.publish_frame(f);
    s = tick(tree, /*new_frame=*/false);
  }
  EXPECT_EQ(s, NodeStatus::failure) << logger_.text;
  EXPECT_EQ(entry(tree, "edge_failure_code"), "input_lost") << entry(tree, "edge_failure");
  EXPECT_NE(entry(tree, "edge_failure").find("on edge " + id), std::string::npos) << entry(tree, "edge_failure");
}

TEST_F(PrimitiveAdapter, TheLostPolicysFailureIsRouteLostAndTheCodeIsClearedAtTheStart) {
  const std::string id = add_edge({7});
  auto tree = test::load_main_tree("<ReplayBlindEdge edge=\"" + id +
                                       "\" speed_mps=\"0.5\" slow_after_m=\"0.1\" max_blind_m=\"0.3\"/>",
                                   registry_, &clock_);
  tree.blackboard().set("edge_failure_code", std::string("stale"));  // a previous edge's
  EXPECT_EQ(tick(tree), NodeStatus::running) << logger_.text;
  EXPECT_EQ(entry(tree, "edge_failure_code"), "");
  EXPECT_EQ(entry(tree, "edge_failure"), "");
  EXPECT_EQ(run(tree), NodeStatus::failure) << logger_.text;
  EXPECT_EQ(entry(tree, "edge_failure_code"), "route_lost") << entry(tree, "edge_failure");
  EXPECT_NE(entry(tree, "edge_failure").find("on edge " + id), std::string::npos) << entry(tree, "edge_failure");
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(PrimitiveAdapter, APrimitivesOwnFailureCarriesItsCodeOrPrimitive) {
  const std::string id = add_edge({7});
  auto losing = test::load_main_tree("<ReplayLosingEdge edge=\"" + id + "\"/>", registry_, &clock_);
  EXPECT_EQ(run(losing), NodeStatus::failure) << logger_.text;
  EXPECT_EQ(entry(losing, "edge_failure"), "lost the test view");
  EXPECT_EQ(entry(losing, "edge_failure_code"), "view_lost");
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  auto giving_up = test::load_main_tree("<ReplayGivingUpEdge edge=\"" + id + "\"/>", registry_, &clock_);
  EXPECT_EQ(run(giving_up), NodeStatus::failure) << logger_.text;
  EXPECT_EQ(entry(giving_up, "edge_failure_code"), "primitive");
}

TEST_F(PrimitiveAdapter, TheFailureCodePortIsDeclaredAndTheCodesAreDistinct) {
  const bt::PortInfo* code = registry_.find("ReplayTestEdge")->find_port("failure_code");
  ASSERT_NE(code, nullptr);
  EXPECT_EQ(code->default_value, "{edge_failure_code}");
  for (std::size_t i = 0; i < replay_failure::all.size(); ++i) {
    EXPECT_FALSE(replay_failure::all[i].empty());
    for (std::size_t j = i + 1; j < replay_failure::all.size(); ++j)
      EXPECT_NE(replay_failure::all[i], replay_failure::all[j]) << i << " " << j;
  }
}

TEST(ParamSchemaCheck, AStructFilledInCodeIsCheckedByTheSchemasRanges) {
  TestParams p;
  EXPECT_TRUE(p.validate().ok());
  p.core.gain = 3.0;
  const Status st = p.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::out_of_range) << st.error().message;
  EXPECT_EQ(st.error().where.key, "core_gain") << st.error().message;
  EXPECT_FALSE(TestParams::schema().check_field("speed_mps", ConfigNode::make_scalar("0.05")).ok());
  EXPECT_TRUE(TestParams::schema().check_field("speed_mps", ConfigNode::make_scalar("0.5")).ok());
}

}  // namespace
}  // namespace visnav
