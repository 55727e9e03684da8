// Navigation nodes, loaded from the real libvisnav_navigation.so through the real loader, on a
// kinematic fake robot. Primitive children are small test nodes following the documented
// protocol ({edge} for replay; {edge_from}/{edge_to}/{finish_edge} for teaching).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <span>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/loader.hpp"
#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

#include "fake_devices.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using bt::NodeStatus;
using visnav::test::KinematicRobot;

namespace {

struct Recorder {
  std::vector<std::string> edges;             // edges replayed, in order
  std::vector<double> heading_at_edge_start;  // robot heading when each edge started
  std::vector<double> carried_m;              // {edge_carried_m} when each edge started
  std::vector<double> distance_scale;         // {edge_distance_scale} when each edge started (unset: 1)
};

/// Replay child: drives the edge's length straight ahead at 1 m/s, counting the distance
/// FollowRoute says is already covered ({edge_carried_m}, unset = 0) as the primitives do.
class TestReplayEdge final : public bt::StatefulActionNode {
 public:
  TestReplayEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host, Recorder& rec)
      : StatefulActionNode(name, config), host_(host), rec_(rec) {}
  static bt::PortsList provided_ports() {
    return {bt::input_port<std::string>("edge", "{edge}", "edge"),
            bt::input_port<double>("carried_m", "{edge_carried_m}", "already covered"),
            bt::input_port<double>("end_early_m", "0", "end this much before the length (a visual correction)"),
            bt::input_port<double>("distance_scale", "{edge_distance_scale}", "odometric m per taught m"),
            bt::input_port<double>("truth_scale", "0",
                                   "> 0: odometry reads this many metres per taught metre, and the child sees where "
                                   "the edge really ends (a visual fix); it counts the edge with distance_scale"),
            bt::input_port<double>("off_route_m", "0",
                                   "drive this much more odometry than the edge takes and report it as travel off the "
                                   "route (a detour's sideways legs, ReplayAvoiding)"),
            bt::output_port<double>("extra_travel_m", "{edge_extra_travel_m}", "odometry driven off the route"),
            bt::output_port<double>("end_shift_m", "{edge_end_shift_m}", "how much earlier it ended")};
  }
  NodeStatus on_start() override {
    auto early = get_input<double>("end_early_m");
    end_early_m_ = early ? *early : 0.0;
    auto off_route = get_input<double>("off_route_m");
    off_route_m_ = off_route ? *off_route : 0.0;
    auto edge = get_input<std::string>("edge");
    if (!edge) return NodeStatus::failure;
    const EdgeRecord* record = host_.map()->find_edge(*edge);
    if (record == nullptr) return NodeStatus::failure;
    rec_.edges.push_back(*edge);
    auto odom = *host_.frame_bus()->latest_odometry();
    rec_.heading_at_edge_start.push_back(odom.pose.heading_rad);
    auto carried = get_input<double>("carried_m");
    rec_.carried_m.push_back(carried ? *carried : 0.0);
    auto scale = get_input<double>("distance_scale");
    scale_ = scale ? *scale : 1.0;
    rec_.distance_scale.push_back(scale_);
    auto truth = get_input<double>("truth_scale");
    truth_scale_ = truth ? *truth : 0.0;
    start_m_ = odom.distance_m - rec_.carried_m.back();
    length_m_ = record->length_m;
    return on_running();
  }
  NodeStatus on_running() override {
    auto odom = *host_.frame_bus()->latest_odometry();
    if (truth_scale_ > 0.0) {
      // Ends where the edge really ends; reports how much earlier than its own count that was.
      if (odom.distance_m - start_m_ >= truth_scale_ * length_m_ - 1e-9) {
        (void)host_.robot()->stop();
        (void)set_output("end_shift_m", length_m_ - (odom.distance_m - start_m_) / scale_);
        return NodeStatus::success;
      }
      (void)host_.robot()->send_command({1.0, 0.0});
      return NodeStatus::running;
    }
    if (odom.distance_m - start_m_ >= length_m_ - end_early_m_ + off_route_m_ - 1e-9) {
      (void)host_.robot()->stop();
      (void)set_output("end_shift_m", end_early_m_);
      if (off_route_m_ > 0.0) (void)set_output("extra_travel_m", off_route_m_);
      return NodeStatus::success;
    }
    (void)host_.robot()->send_command({1.0, 0.0});
    return NodeStatus::running;
  }
  void on_halted() override { (void)host_.robot()->stop(); }

 private:
  HostServices& host_;
  Recorder& rec_;
  double start_m_ = 0, length_m_ = 0, end_early_m_ = 0, scale_ = 1, truth_scale_ = 0, off_route_m_ = 0;
};

/// Teach child: records the distance while the operator drives; on {finish_edge} writes the
/// edge with its length, azimuth and end heading.
class TestTeachEdge final : public bt::StatefulActionNode {
 public:
  TestTeachEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}
  static bt::PortsList provided_ports() {
    return {bt::input_port<std::string>("edge_from", "{edge_from}", ""),
            bt::input_port<std::string>("edge_to", "{edge_to}", ""),
            bt::input_port<bool>("finish", "{finish_edge}", ""),
            bt::input_port<std::string>("kind", "feature_segment", ""),
            bt::output_port<std::string>("edge", "{taught_edge}", "")};
  }
  NodeStatus on_start() override {
    auto odom = *host_.frame_bus()->latest_odometry();
    start_m_ = odom.distance_m;
    azimuth_ = odom.pose.heading_rad;
    return on_running();
  }
  NodeStatus on_running() override {
    auto finish = get_input<bool>("finish");
    if (!finish || !*finish) return NodeStatus::running;
    auto odom = *host_.frame_bus()->latest_odometry();
    EdgeRecord e;
    e.from = *get_input<std::string>("edge_from");
    e.to = *get_input<std::string>("edge_to");
    e.kind = *get_input<std::string>("kind");
    e.length_m = odom.distance_m - start_m_;
    e.azimuth_rad = azimuth_;
    e.statistics["end_heading_rad"] = odom.pose.heading_rad;
    std::vector<std::uint8_t> payload{1, 2, 3};
    auto id = host_.map()->add_edge(e, payload);
    if (!id) return NodeStatus::failure;
    (void)set_output("edge", *id);
    return NodeStatus::success;
  }
  void on_halted() override {}

 private:
  HostServices& host_;
  double start_m_ = 0, azimuth_ = 0;
};

/// Scripted "operator" for teaching: a list of legs (kind, distance, turn before it).
struct Leg {
  std::string kind;
  double turn_rad;
  double length_m;
};

class NavigationNodes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = visnav::test::fresh_test_dir("visnav_nav_nodes");
    ASSERT_TRUE(visnav::test::attach_scratch_map(host_, bus_, robot_, map_, dir_));
    ASSERT_TRUE(visnav::test::register_plugin_nodes(loader_, "navigation", registry_, host_));
    auto* host = &host_;
    auto* rec = &rec_;
    ASSERT_TRUE((registry_.register_node<TestReplayEdge>(
                     "TestReplayEdge", "",
                     [host, rec](const std::string& n, const bt::NodeConfig& c) {
                       return std::make_unique<TestReplayEdge>(n, c, *host, *rec);
                     }))
                    .ok());
    ASSERT_TRUE((registry_.register_node<TestTeachEdge>("TestTeachEdge", "",
                                                        [host](const std::string& n, const bt::NodeConfig& c) {
                                                          return std::make_unique<TestTeachEdge>(n, c, *host);
                                                        }))
                    .ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  bt::Tree load(const std::string& body) { return visnav::test::load_main_tree(body, registry_, &clock_); }

  /// A TeachRoute (extra attributes `attributes`) over TestTeachEdge for feature_segment, the
  /// operator asking for a feature_segment edge and driving 1 m/s.
  bt::Tree teach_route(const std::string& attributes = "") {
    auto tree = load("<TeachRoute" + attributes +
                     " primitives=\"feature_segment=TestTeachEdge\"><TestTeachEdge/></TeachRoute>");
    tree.blackboard().set("primitive", std::string("feature_segment"));
    tree.blackboard().set("teach_done", false);
    (void)robot_.send_command({1.0, 0.0});
    return tree;
  }

  /// Ticks at 10 Hz until the tree finishes (or max_ticks), stepping the robot after each tick.
  NodeStatus run(bt::Tree& tree, int max_ticks = 5000, const std::function<void(int)>& before_tick = {}) {
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < max_ticks && s == NodeStatus::running; ++i) {
      if (before_tick) before_tick(i);
      s = tree.tick_once();
      robot_.step(0.1);
      clock_.advance(0.1);
    }
    return s;
  }

  std::string node(const std::string& name) {
    NodeRecord n;
    n.name = name;
    return *map_->add_node(n);
  }
  std::string edge(const std::string& from, const std::string& to, double length_m, double azimuth_rad,
                   double end_heading_rad, const std::string& kind = "feature_segment") {
    EdgeRecord e;
    e.from = from;
    e.to = to;
    e.kind = kind;
    e.length_m = length_m;
    e.azimuth_rad = azimuth_rad;
    e.statistics["end_heading_rad"] = end_heading_rad;
    std::vector<std::uint8_t> payload{0};
    return *map_->add_edge(e, payload);
  }

  fs::path dir_;
  PluginLoader loader_{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  StderrLogger logger_{LogLevel::warn};
  ManualClock clock_;
  RuntimeHost host_{loader_, logger_, clock_};
  FrameBus bus_;
  KinematicRobot robot_{bus_};
  std::optional<MapStore> map_;
  bt::NodeRegistry registry_;
  Recorder rec_;
};

}  // namespace

TEST_F(NavigationNodes, PlanRouteWritesShortestRouteAndLength) {
  auto a = node("A"), b = node("B"), c = node("C");
  auto ab = edge(a, b, 5, 0, 0);
  auto bc = edge(b, c, 5, 0, 0);
  edge(a, c, 20, 0, 0, "path_following");
  auto tree = load(R"(<PlanRoute start="A" goal="C"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<std::vector<std::string>>("route"), (std::vector<std::string>{ab, bc}));
  EXPECT_DOUBLE_EQ(*tree.blackboard().get<double>("route_length_m"), 10.0);
}

TEST_F(NavigationNodes, PlanRouteKindCostsChangeTheRoute) {
  auto a = node("A"), b = node("B"), c = node("C");
  edge(a, b, 5, 0, 0);
  edge(b, c, 5, 0, 0);
  auto ac = edge(a, c, 12, 0, 0, "path_following");
  auto tree = load(R"(<PlanRoute start="A" goal="C" kind_costs="path_following=0.5"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<std::vector<std::string>>("route"), (std::vector<std::string>{ac}));
}

TEST_F(NavigationNodes, PlanRouteFailsForUnknownNodeAndUnreachableGoal) {
  auto a = node("A");
  node("B");
  (void)a;
  auto unknown = load(R"(<PlanRoute start="A" goal="Nowhere"/>)");
  EXPECT_EQ(unknown.tick_once(), NodeStatus::failure);
  auto unreachable = load(R"(<PlanRoute start="A" goal="B"/>)");
  EXPECT_EQ(unreachable.tick_once(), NodeStatus::failure);
}

TEST_F(NavigationNodes, PlanRouteWithStartEqualGoalPlansTheLoop) {
  auto a = node("A"), b = node("B");
  auto ab = edge(a, b, 5, 0, 0);
  auto ba = edge(b, a, 5, 0, 0);
  auto tree = load(R"(<PlanRoute start="A" goal="A"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<std::vector<std::string>>("route"), (std::vector<std::string>{ab, ba}));
}

TEST_F(NavigationNodes, TurnToAzimuthReachesTargetWithinTolerance) {
  auto tree = load(R"(<TurnToAzimuth azimuth_rad="1.2" turn_tolerance_rad="0.01"/>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  EXPECT_NEAR(robot_.odom_.pose.heading_rad, 1.2, 0.02);
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);  // stopped at the end
}

TEST_F(NavigationNodes, TurnToAzimuthRelativeAndShortestDirection) {
  robot_.odom_.pose.heading_rad = 3.0;
  robot_.publish();
  auto tree = load(R"(<TurnToAzimuth azimuth_rad="-3.0"/>)");  // shortest way is +0.28 rad, not -6
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_GT(robot_.command_.angular_radps, 0.0);
  EXPECT_EQ(run(tree), NodeStatus::success);
  EXPECT_NEAR(std::remainder(robot_.odom_.pose.heading_rad + 3.0, 2 * std::numbers::pi), 0.0, 0.03);
}

TEST_F(NavigationNodes, TurnToAzimuthHaltStopsTheRobot) {
  auto tree = load(R"(<TurnToAzimuth azimuth_rad="2.0"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_NE(robot_.command_.angular_radps, 0.0);
  tree.halt();
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);
}

TEST_F(NavigationNodes, TurnToAzimuthFailsAndStopsWhenTheRobotRefusesItsCommand) {
  robot_.refuse_commands_ = true;
  auto tree = load(R"(<TurnToAzimuth azimuth_rad="2.0"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);
}

TEST_F(NavigationNodes, AtNodeComparesIdsAndNames) {
  auto a = node("A");
  node("B");
  auto tree = load(R"(<Sequence><SetBlackboard output_key="current_node" value=")" + a +
                   R"("/><AtNode node="A"/><Inverter><AtNode node="B"/></Inverter></Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
}

TEST_F(NavigationNodes, FollowRouteRunsEdgesInOrderAndTurnsRelativelyAtNodes) {
  auto a = node("A"), b = node("B"), c = node("C");
  // edge 1 heads east and ends heading east; edge 2 starts heading north: a +90° turn at B.
  auto ab = edge(a, b, 2.0, 0.0, 0.0);
  auto bc = edge(b, c, 3.0, std::numbers::pi / 2, std::numbers::pi / 2);
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge">
        <TestReplayEdge/></FollowRoute></Sequence>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.edges, (std::vector<std::string>{ab, bc}));
  EXPECT_NEAR(rec_.heading_at_edge_start[1] - rec_.heading_at_edge_start[0], std::numbers::pi / 2, 0.02);
  EXPECT_NEAR(robot_.odom_.distance_m, 5.0, 0.15);
  EXPECT_EQ(*tree.blackboard().get<std::string>("current_node"), c);
  EXPECT_EQ(*tree.blackboard().get<std::string>("previous_edge"), bc);
}

TEST_F(NavigationNodes, FollowRouteTurnsAfterAPathEdgeFromItsTaughtEndHeading) {
  // The teach odometry drifted 0.3 rad over a straight path edge (azimuth 0, end heading 0.3) and
  // the next edge continues straight on (azimuth 0.3 in that odometry): no turn at B. Measuring the
  // turn from the path edge's start heading (the old rule for path edges) turned the robot 0.3 rad
  // off the route there (issue 12, campus e14 -> e15).
  auto a = node("A"), b = node("B"), c = node("C");
  edge(a, b, 2.0, 0.0, 0.3, "path_following");
  edge(b, c, 1.0, 0.3, 0.3);
  const char* kinds = R"(primitives="feature_segment=TestReplayEdge;path_following=TestReplayEdge")";
  auto tree = load(std::string(R"(<Sequence><PlanRoute start="A" goal="C"/><FollowRoute turn_tolerance_rad="0.01" )") +
                   kinds + "><TestReplayEdge/></FollowRoute></Sequence>");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.heading_at_edge_start.size(), 2u);
  EXPECT_NEAR(rec_.heading_at_edge_start[1] - rec_.heading_at_edge_start[0], 0.0, 0.02);
  // A tree that takes path edges out of heading_holding_kinds gets the start-heading rule back.
  rec_ = Recorder{};
  auto old_rule = load(std::string(R"(<Sequence><PlanRoute start="A" goal="C"/><FollowRoute turn_tolerance_rad="0.01" )") +
                       "heading_holding_kinds=\"feature_segment\" " + kinds +
                       "><TestReplayEdge/></FollowRoute></Sequence>");
  EXPECT_EQ(run(old_rule), NodeStatus::success);
  ASSERT_EQ(rec_.heading_at_edge_start.size(), 2u);
  EXPECT_NEAR(rec_.heading_at_edge_start[1] - rec_.heading_at_edge_start[0], 0.3, 0.02);
}

// Issue 17: a damaged payload further along the route fails the mission before the robot moves.
std::string g_damaged_edge;
Status refuse_damaged(std::span<const std::uint8_t>, const EdgeRecord& e) noexcept {
  if (e.id == g_damaged_edge) return fail("body does not decode");
  return ok();
}

TEST_F(NavigationNodes, FollowRouteChecksEveryPayloadOfTheRouteBeforeMoving) {
  auto a = node("A"), b = node("B"), c = node("C");
  auto ab = edge(a, b, 2.0, 0.0, 0.0);
  auto bc = edge(b, c, 3.0, 0.0, 0.0);
  g_damaged_edge = bc;
  map_->set_payload_check("feature_segment", &refuse_damaged);
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute></Sequence>)");
  EXPECT_EQ(run(tree), NodeStatus::failure);
  EXPECT_TRUE(rec_.edges.empty());                 // not even the good first edge was started
  EXPECT_NEAR(robot_.odom_.distance_m, 0.0, 1e-9);  // the robot never moved
  map_->set_payload_check("feature_segment", nullptr);
  auto again = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute></Sequence>)");
  EXPECT_EQ(run(again), NodeStatus::success);  // the same route without the damage
}

TEST_F(NavigationNodes, FollowRouteCarriesTheOvershootIntoAStraightContinuation) {
  // Three edges of 2.05 m; the robot moves 0.1 m per tick, so each edge's primitive stops 0.05 m
  // past its end node. A → B → C go straight on (the overshoot is carried: the robot must stop
  // at 4.1 m, where C is, not at 4.2 m); C → D turns +90°, where the overshoot is sideways.
  auto a = node("A"), b = node("B"), c = node("C"), d = node("D");
  const double q = std::numbers::pi / 2;
  edge(a, b, 2.05, 0.0, 0.0);
  edge(b, c, 2.05, 0.0, 0.0);
  edge(c, d, 2.05, q, q);
  auto run_to = [&](const std::string& goal, const std::string& carry) {
    rec_ = Recorder{};
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = load(R"(<Sequence><PlanRoute start="A" goal=")" + goal + R"("/>
        <FollowRoute turn_tolerance_rad="0.01" carry_overshoot=")" + carry +
                     R"(" primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute></Sequence>)");
    EXPECT_EQ(run(tree), NodeStatus::success);
    return robot_.odom_.distance_m;
  };
  EXPECT_NEAR(run_to("C", "false"), 4.2, 1e-6);  // each edge counted from where the robot stopped
  EXPECT_NEAR(run_to("C", "true"), 4.1, 1e-6);
  ASSERT_EQ(rec_.carried_m.size(), 2u);
  EXPECT_DOUBLE_EQ(rec_.carried_m[0], 0.0);  // first edge of the run: nothing to carry
  EXPECT_NEAR(rec_.carried_m[1], 0.05, 1e-6);
  run_to("D", "true");
  ASSERT_EQ(rec_.carried_m.size(), 3u);
  EXPECT_NEAR(rec_.carried_m[2], 0.0, 1e-6);  // the 90° turn: the overshoot is lateral, not along C → D
}

TEST_F(NavigationNodes, FollowRouteCarriesFromWhereTheChildEndedTheEdge) {
  // The child ends each edge 0.3 m before its odometric length (an along-track correction: the
  // taught end view was seen there) and says so ({edge_end_shift_m}). It stops 0.05 m past that
  // point, and only those 0.05 m are carried into the straight continuation, not −0.25 m (which
  // would undo the correction on the next edge).
  auto a = node("A"), b = node("B"), c = node("C");
  edge(a, b, 2.05, 0.0, 0.0);
  edge(b, c, 2.05, 0.0, 0.0);
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge end_early_m="0.3"/></FollowRoute>
      </Sequence>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.carried_m.size(), 2u);
  EXPECT_NEAR(rec_.carried_m[1], 0.05, 1e-6);
  EXPECT_NEAR(robot_.odom_.distance_m, 3.5, 1e-6);  // both ends 0.3 m early: 4.1 − 0.6
}

TEST_F(NavigationNodes, FollowRouteLeavesTheTravelOffTheRouteOutOfTheCarriedDistance) {
  // The child drove 0.6 m of odometry beside its edges (a detour) and says so
  // ({edge_extra_travel_m}): only the 0.05 m it stopped past the end node are carried into the
  // straight continuation, not the 0.65 m the odometer shows (clamped to max_carry_m 0.5, the
  // next edge would start half a metre ahead of where the robot is).
  auto a = node("A"), b = node("B"), c = node("C");
  edge(a, b, 2.05, 0.0, 0.0);
  edge(b, c, 2.05, 0.0, 0.0);
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge off_route_m="0.6"/></FollowRoute>
      </Sequence>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.carried_m.size(), 2u);
  EXPECT_NEAR(rec_.carried_m[1], 0.05, 1e-6);
  EXPECT_NEAR(robot_.odom_.distance_m, 4.1 + 2 * 0.6, 1e-6);

  // A child that never writes the entry (the plain replay nodes) leaves no stale value behind:
  // FollowRoute resets it at every edge start, so a leftover 5 m is not taken off the route.
  rec_ = Recorder{};
  robot_.odom_ = Odometry{};
  robot_.publish();
  auto plain = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute>
      </Sequence>)");
  plain.blackboard().set("edge_extra_travel_m", 5.0);
  EXPECT_EQ(run(plain), NodeStatus::success);
  ASSERT_EQ(rec_.carried_m.size(), 2u);
  EXPECT_NEAR(rec_.carried_m[1], 0.05, 1e-6);
}

TEST_F(NavigationNodes, FollowRouteLearnsTheOdometryScaleFromVisualFixes) {
  // Odometry reads 5 % more than when the route was taught. The child sees where each edge
  // really ends (a visual fix) and reports it as end_shift_m; once the fixes span 15 m of taught
  // distance, FollowRoute hands the scale to the next edge ({edge_distance_scale}), whose count
  // then ends where the edge ends (shift 0). Off, every edge is counted with scale 1.
  auto a = node("A"), b = node("B"), c = node("C"), d = node("D"), e = node("E");
  edge(a, b, 10.0, 0.0, 0.0);
  edge(b, c, 10.0, 0.0, 0.0);
  edge(c, d, 10.0, 0.0, 0.0);
  edge(d, e, 10.0, 0.0, 0.0);
  auto run_with = [&](const std::string& on, const std::string& fix_kinds = "") {
    rec_ = Recorder{};
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = load(R"(<Sequence><PlanRoute start="A" goal="E"/>
        <FollowRoute turn_tolerance_rad="0.01" carry_overshoot="false" scale_min_baseline_m="15" scale_distance=")" +
                     on + R"(" scale_fix_kinds=")" + fix_kinds +
                     R"(" primitives="feature_segment=TestReplayEdge"><TestReplayEdge truth_scale="1.05"/></FollowRoute>
        </Sequence>)");
    EXPECT_EQ(run(tree), NodeStatus::success);
    EXPECT_NEAR(robot_.odom_.distance_m, 42.0, 0.11);  // the child ends every edge where it really ends
    return tree.blackboard().get<double>("edge_distance_scale");
  };
  auto last = run_with("true");
  ASSERT_EQ(rec_.distance_scale.size(), 4u);
  EXPECT_DOUBLE_EQ(rec_.distance_scale[0], 1.0);
  EXPECT_DOUBLE_EQ(rec_.distance_scale[1], 1.0);  // one fix: no slope yet
  EXPECT_DOUBLE_EQ(rec_.distance_scale[2], 1.0);  // two fixes 10 m apart: below the 15 m baseline
  EXPECT_NEAR(rec_.distance_scale[3], 1.05, 0.006);
  ASSERT_TRUE(last.ok());
  EXPECT_NEAR(*last, 1.05, 0.006);
  last = run_with("false");
  ASSERT_EQ(rec_.distance_scale.size(), 4u);
  EXPECT_DOUBLE_EQ(rec_.distance_scale[3], 1.0);
  // scale_fix_kinds: the ends of feature edges are no fixes when only path edges' count (the
  // campus tree's setting), and fixes again when the list names their kind.
  (void)run_with("true", "path_following");
  ASSERT_EQ(rec_.distance_scale.size(), 4u);
  EXPECT_DOUBLE_EQ(rec_.distance_scale[3], 1.0);
  (void)run_with("true", "path_following, feature_segment");
  ASSERT_EQ(rec_.distance_scale.size(), 4u);
  EXPECT_NEAR(rec_.distance_scale[3], 1.05, 0.006);
}

TEST_F(NavigationNodes, FollowRouteSubtractsTheGapTaughtBetweenEdges) {
  // The teacher also rolled 0.03 m past B before the next edge started (statistic start_gap_m):
  // only the remaining 0.02 m of the replay's 0.05 m overshoot is carried.
  auto a = node("A"), b = node("B"), c = node("C");
  edge(a, b, 2.05, 0.0, 0.0);
  auto bc = edge(b, c, 2.05, 0.0, 0.0);
  ASSERT_TRUE(map_->set_edge_statistic(bc, "start_gap_m", 0.03).ok());
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="C"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute>
      </Sequence>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.carried_m.size(), 2u);
  EXPECT_NEAR(rec_.carried_m[1], 0.02, 1e-6);
  EXPECT_NEAR(*tree.blackboard().get<double>("edge_carried_m"), 0.02, 1e-6);
}

TEST_F(NavigationNodes, FollowRouteFailsClearlyWhenNoChildHandlesAKind) {
  auto a = node("A"), b = node("B");
  edge(a, b, 2.0, 0.0, 0.0, "path_following");
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="B"/>
      <FollowRoute primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute></Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_TRUE(rec_.edges.empty());
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
}

TEST_F(NavigationNodes, FollowRouteHaltStopsRobotAndChild) {
  auto a = node("A"), b = node("B");
  edge(a, b, 50.0, 0.0, 0.0);
  auto tree = load(R"(<Sequence><PlanRoute start="A" goal="B"/>
      <FollowRoute primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute></Sequence>)");
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(tree.tick_once(), NodeStatus::running);
    robot_.step(0.1);
  }
  EXPECT_GT(robot_.command_.linear_mps, 0.0);
  tree.halt();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(NavigationNodes, PatrolLoopTurnsRelativeToThePreviousLoopsLastEdge) {
  // A square loop; after the first lap the robot turns +90° from the last edge into the first.
  auto a = node("A"), b = node("B"), c = node("C"), d = node("D");
  const double q = std::numbers::pi / 2;
  edge(a, b, 1.0, 0.0, 0.0);
  edge(b, c, 1.0, q, q);
  edge(c, d, 1.0, 2 * q, 2 * q);
  edge(d, a, 1.0, -q, -q);
  auto tree = load(R"(<Repeat num_cycles="2"><Sequence><PlanRoute start="A" goal="A"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute>
      </Sequence></Repeat>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.edges.size(), 8u);
  // back at the start after two laps, heading east again (4 full turns of +90°)
  EXPECT_NEAR(robot_.odom_.pose.x_m, 0.0, 0.1);
  EXPECT_NEAR(robot_.odom_.pose.y_m, 0.0, 0.1);
  EXPECT_NEAR(rec_.heading_at_edge_start[4] - rec_.heading_at_edge_start[3], q, 0.02);
}

TEST_F(NavigationNodes, PatrolLoopTurnsIntoTheNextLapByTheRecordedClosingTurn) {
  // The same square, taught with 0.5 rad of odometric heading drift over the loop: the last
  // edge's headings read 0.5 rad too far left, so the azimuths alone ask for a 1.07 rad turn
  // into the next lap. The closing turn the operator made (and TeachRoute recorded) is 90°.
  auto a = node("A"), b = node("B"), c = node("C"), d = node("D");
  const double q = std::numbers::pi / 2;
  const double drift = 0.5;
  edge(a, b, 1.0, 0.0, 0.0);
  edge(b, c, 1.0, q, q);
  edge(c, d, 1.0, 2 * q, 2 * q);
  const std::string last = edge(d, a, 1.0, -q + drift, -q + drift);
  ASSERT_TRUE(map_->set_edge_statistic(last, "closing_turn_rad", q).ok());
  auto tree = load(R"(<Repeat num_cycles="2"><Sequence><PlanRoute start="A" goal="A"/>
      <FollowRoute turn_tolerance_rad="0.01" primitives="feature_segment=TestReplayEdge"><TestReplayEdge/></FollowRoute>
      </Sequence></Repeat>)");
  EXPECT_EQ(run(tree), NodeStatus::success);
  ASSERT_EQ(rec_.edges.size(), 8u);
  EXPECT_NEAR(rec_.heading_at_edge_start[4] - rec_.heading_at_edge_start[3], q, 0.02);
}

TEST_F(NavigationNodes, TeachRouteRecordsTheClosingTurnOfAClosedRoute) {
  // One edge driven east; the operator then signals closing and turns +90° in place before
  // saying done: the edge ends on the start node and carries that turn.
  auto tree = teach_route(" close_loop=\"true\"");
  auto& bb = tree.blackboard();
  bb.set("teach_closing", false);
  double turn_start_heading = 0.0;
  bool turning = false;
  auto op = [&](int i) {
    const auto& o = robot_.odom_;
    if (i == 10) {
      bb.set("primitive", std::string());
      bb.set("teach_closing", true);
      turning = true;
      turn_start_heading = o.pose.heading_rad;
      (void)robot_.send_command({0.0, 0.5});
    }
    if (turning && o.pose.heading_rad - turn_start_heading >= std::numbers::pi / 2) {
      (void)robot_.send_command({0.0, 0.0});
      bb.set("teach_done", true);
      turning = false;
    }
  };
  EXPECT_EQ(run(tree, 200, op), NodeStatus::success);
  ASSERT_EQ(map_->edges().size(), 1u);
  const auto& e = map_->edges()[0];
  EXPECT_EQ(e.from, e.to);
  EXPECT_NEAR(e.length_m, 1.0, 0.15);
  ASSERT_EQ(e.statistics.count("closing_turn_rad"), 1u);
  EXPECT_NEAR(e.statistics.at("closing_turn_rad"), std::numbers::pi / 2, 0.08);
  // The end heading is the one before the closing turn, not after it.
  EXPECT_NEAR(e.statistics.at("end_heading_rad"), 0.0, 0.06);
}

TEST_F(NavigationNodes, TeachRouteCreatesANodeAndEdgeAtEveryPrimitiveSwitch) {
  // Operator script: 2 m feature, turn +90°, 3 m path, then done (closing the loop is off).
  auto tree = load(R"(<TeachRoute start_node="dock" primitives="feature_segment=TestTeachEdge;path_following=TestTeachEdge">
      <TestTeachEdge/></TeachRoute>)");
  auto& bb = tree.blackboard();
  bb.set("primitive", std::string());
  bb.set("teach_done", false);
  int phase = 0;
  double phase_start_m = 0.0;
  double phase_start_heading = 0.0;
  auto op = [&](int) {
    const auto& o = robot_.odom_;
    switch (phase) {
      case 0:
        bb.set("primitive", std::string("feature_segment"));
        (void)robot_.send_command({1.0, 0.0});
        phase = 1;
        phase_start_m = o.distance_m;
        break;
      case 1:
        if (o.distance_m - phase_start_m >= 2.0) {
          bb.set("primitive", std::string());
          phase = 2;
          phase_start_heading = o.pose.heading_rad;
          (void)robot_.send_command({0.0, 0.5});
        }
        break;
      case 2:
        if (o.pose.heading_rad - phase_start_heading >= std::numbers::pi / 2) {
          bb.set("primitive", std::string("path_following"));
          (void)robot_.send_command({1.0, 0.0});
          phase = 3;
          phase_start_m = o.distance_m;
        }
        break;
      case 3:
        if (o.distance_m - phase_start_m >= 3.0) {
          (void)robot_.send_command({0.0, 0.0});
          bb.set("teach_done", true);
          phase = 4;
        }
        break;
      default:
        break;
    }
  };
  EXPECT_EQ(run(tree, 500, op), NodeStatus::success);
  ASSERT_EQ(map_->edges().size(), 2u);
  ASSERT_EQ(map_->nodes().size(), 3u);
  EXPECT_EQ(map_->nodes()[0].name, "dock");
  const auto& e1 = map_->edges()[0];
  const auto& e2 = map_->edges()[1];
  EXPECT_NEAR(e1.length_m, 2.0, 0.15);
  EXPECT_NEAR(e2.length_m, 3.0, 0.15);
  EXPECT_EQ(e1.to, e2.from);
  EXPECT_NEAR(e2.azimuth_rad - e1.statistics.at("end_heading_rad"), std::numbers::pi / 2, 0.1);
  EXPECT_EQ(*bb.get<std::vector<std::string>>("taught_route"), (std::vector<std::string>{e1.id, e2.id}));
  // The map on disk reloads with both edges.
  auto reopened = MapStore::open(dir_.string());
  ASSERT_TRUE(reopened.ok()) << reopened.error().message;
  EXPECT_EQ(reopened->edges().size(), 2u);
  EXPECT_TRUE(reopened->validate().empty());
}

TEST_F(NavigationNodes, TeachRouteRecordsHowFarTheRobotRolledBetweenEdges) {
  // Edge 1 ends at tick 10; the robot rolls on for 3 ticks (0.3 m) before edge 2 starts.
  auto tree = teach_route();
  auto& bb = tree.blackboard();
  auto op = [&](int i) {
    if (i == 10) bb.set("primitive", std::string());
    if (i == 13) bb.set("primitive", std::string("feature_segment"));
    if (i == 20) bb.set("teach_done", true);
  };
  EXPECT_EQ(run(tree, 100, op), NodeStatus::success);
  ASSERT_EQ(map_->edges().size(), 2u);
  EXPECT_EQ(map_->edges()[0].statistics.count("start_gap_m"), 0u);  // the first edge has no predecessor
  ASSERT_EQ(map_->edges()[1].statistics.count("start_gap_m"), 1u);
  EXPECT_NEAR(map_->edges()[1].statistics.at("start_gap_m"), 0.3, 1e-6);
}

TEST_F(NavigationNodes, TeachRouteClosesTheLoopOnTheStartNode) {
  auto tree = teach_route(" close_loop=\"true\"");
  auto& bb = tree.blackboard();
  auto op = [&](int i) {
    if (i == 20) bb.set("teach_done", true);
  };
  EXPECT_EQ(run(tree, 100, op), NodeStatus::success);
  ASSERT_EQ(map_->edges().size(), 1u);
  EXPECT_EQ(map_->edges()[0].from, map_->edges()[0].to);
  EXPECT_EQ(map_->nodes().size(), 1u);
}

TEST_F(NavigationNodes, TeachRouteHaltKeepsCompletedEdgesOnly) {
  auto tree = teach_route();
  auto& bb = tree.blackboard();
  auto op = [&](int i) {
    if (i == 10) bb.set("primitive", std::string());      // end edge 1
    if (i == 12) bb.set("primitive", std::string("feature_segment"));  // start edge 2
  };
  for (int i = 0; i < 20; ++i) {
    op(i);
    EXPECT_EQ(tree.tick_once(), NodeStatus::running);
    robot_.step(0.1);
  }
  tree.halt();  // interrupted while teaching edge 2
  EXPECT_EQ(map_->edges().size(), 1u);
  auto reopened = MapStore::open(dir_.string());
  ASSERT_TRUE(reopened.ok());
  EXPECT_EQ(reopened->edges().size(), 1u);
}

TEST_F(NavigationNodes, TeachRouteRejectsUnmappedKind) {
  auto tree = load(R"(<TeachRoute primitives="feature_segment=TestTeachEdge"><TestTeachEdge/></TeachRoute>)");
  tree.blackboard().set("primitive", std::string("teleport"));
  tree.blackboard().set("teach_done", false);
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
}
