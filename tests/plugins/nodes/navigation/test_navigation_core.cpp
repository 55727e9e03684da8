#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>

#include "error_expect.hpp"
#include "visnav_navigation/navigation_core.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::nav;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(NavigationCore, WrapAngleStaysInHalfOpenInterval) {
  EXPECT_NEAR(wrap_angle_rad(3 * std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-3 * std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(2 * std::numbers::pi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-0.1), -0.1, 1e-12);
}

TEST(NavigationCore, TurnCommandSaturatesHasFloorAndStopsInsideTolerance) {
  TurnParams p;
  EXPECT_EQ(turn_command_radps(0.01, p), 0.0);
  EXPECT_NEAR(turn_command_radps(1.0, p), p.max_angular_radps, 1e-12);
  EXPECT_NEAR(turn_command_radps(-1.0, p), -p.max_angular_radps, 1e-12);
  EXPECT_NEAR(turn_command_radps(0.03, p), p.min_angular_radps, 1e-12);  // 1.5*0.03 < floor
  EXPECT_NEAR(turn_command_radps(0.2, p), 0.3, 1e-12);
}

TEST(NavigationCore, ArcTurnNeverExceedsTheCurvatureBoundAndDrivesTheTurnToItsEnd) {
  TurnParams turn;
  ArcTurnParams arc;
  arc.min_turning_radius_m = 1.5;
  arc.speed_mps = 0.3;
  ASSERT_TRUE(arc.validate().ok());
  // Over the whole range of errors: forward, |w| / v <= 1 / R, the turn's sign.
  for (double e = -3.1; e <= 3.1; e += 0.01) {
    const Twist c = arc_turn_command(e, turn, arc);
    if (std::abs(e) <= turn.tolerance_rad) {
      EXPECT_EQ(c.linear_mps, 0.0);
      EXPECT_EQ(c.angular_radps, 0.0);
      continue;
    }
    EXPECT_EQ(c.linear_mps, 0.3);
    EXPECT_LE(std::abs(c.angular_radps) / c.linear_mps, 1.0 / 1.5 + 1e-12) << e;
    EXPECT_GT(c.angular_radps * e, 0.0) << e;
  }
  EXPECT_NEAR(arc_turn_command(1.0, turn, arc).angular_radps, 0.2, 1e-12);  // saturated at v / R
  // Integrated, a 90-degree arc turn ends within tolerance having moved about R along and R across.
  double x = 0, y = 0, h = 0;
  int ticks = 0;
  for (; ticks < 1000; ++ticks) {
    const Twist c = arc_turn_command(wrap_angle_rad(std::numbers::pi / 2 - h), turn, arc);
    if (c.linear_mps == 0.0) break;
    h += c.angular_radps * 0.02;
    x += c.linear_mps * 0.02 * std::cos(h);
    y += c.linear_mps * 0.02 * std::sin(h);
  }
  ASSERT_LT(ticks, 1000);
  EXPECT_NEAR(h, std::numbers::pi / 2, turn.tolerance_rad + 1e-9);
  EXPECT_NEAR(x, 1.5, 0.05);
  EXPECT_GT(y, 1.5);  // the proportional tail goes on a little past the ideal arc's end
  EXPECT_LT(y, 1.8);
  // R = 0: the in-place turn, unchanged (diff-drive).
  EXPECT_EQ(arc_turn_command(0.2, turn, ArcTurnParams{}).linear_mps, 0.0);
  EXPECT_EQ(arc_turn_command(0.2, turn, ArcTurnParams{}).angular_radps, turn_command_radps(0.2, turn));
  // Bad parameters name the key.
  ArcTurnParams bad;
  bad.min_turning_radius_m = -0.5;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("min_turning_radius_m")));
  bad = ArcTurnParams{};
  bad.speed_mps = 0.0;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("arc_speed_mps")));
}

TEST(NavigationCore, TurnParamsValidation) {
  TurnParams p;
  EXPECT_TRUE(p.validate().ok());
  p.tolerance_rad = 0;
  EXPECT_FALSE(p.validate().ok());
  p = TurnParams{};
  p.min_angular_radps = 2.0;
  EXPECT_FALSE(p.validate().ok());
}

TEST(NavigationCore, RelativeTurnUsesRecordedEndHeading) {
  EdgeRecord a;
  a.azimuth_rad = 0.0;
  a.statistics["end_heading_rad"] = 0.2;
  EdgeRecord b;
  b.azimuth_rad = std::numbers::pi / 2;
  EXPECT_NEAR(turn_between_edges_rad(a, b), std::numbers::pi / 2 - 0.2, 1e-12);
  a.statistics.clear();
  EXPECT_NEAR(turn_between_edges_rad(a, b), std::numbers::pi / 2, 1e-12);
  // wraps across ±pi
  a.azimuth_rad = 3.0;
  b.azimuth_rad = -3.0;
  EXPECT_NEAR(turn_between_edges_rad(a, b), 2 * std::numbers::pi - 6.0, 1e-12);
}

TEST(NavigationCore, KindMapParsingAndErrors) {
  auto m = parse_kind_map({"feature_segment=ReplayFeatureEdge", " path_following = FollowPathEdge "});
  ASSERT_TRUE(m.ok()) << m.error().message;
  ASSERT_NE(find_kind(*m, "path_following"), nullptr);
  EXPECT_EQ(*find_kind(*m, "path_following"), "FollowPathEdge");
  EXPECT_EQ(find_kind(*m, "other"), nullptr);
  auto bad = parse_kind_map({"feature_segment"});
  EXPECT_TRUE(fails_with(bad, ErrorCode::invalid_value, key_only("feature_segment")));
  EXPECT_FALSE(parse_kind_map({"a=X", "a=Y"}).ok());
}

TEST(NavigationCore, KindCostParsing) {
  auto c = parse_kind_costs({"path_following=0.5", "feature_segment=inf"});
  ASSERT_TRUE(c.ok());
  EXPECT_DOUBLE_EQ(c->kind_multiplier.at("path_following"), 0.5);
  EXPECT_TRUE(std::isinf(c->kind_multiplier.at("feature_segment")));
  EXPECT_FALSE(parse_kind_costs({"a=0"}).ok());
  EXPECT_FALSE(parse_kind_costs({"a=x"}).ok());
}

namespace {
fs::path temp_map_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("visnav_nav_core_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}
std::string add_edge(MapStore& map, const std::string& from, const std::string& to, double length_m,
                     const std::string& kind = "feature_segment") {
  EdgeRecord e;
  e.from = from;
  e.to = to;
  e.kind = kind;
  e.length_m = length_m;
  std::vector<std::uint8_t> payload(8, 1);
  auto id = map.add_edge(e, payload);
  EXPECT_TRUE(id.ok()) << (id.ok() ? "" : id.error().message);
  return id.ok() ? *id : std::string();
}
}  // namespace

TEST(NavigationCore, PlanCycleFindsTheCheapestLoopThroughANode) {
  auto dir = temp_map_dir("cycle");
  auto map = MapStore::create(dir.string(), "cycle");
  ASSERT_TRUE(map.ok()) << map.error().message;
  map->set_sync(false);
  NodeRecord n;
  n.name = "a";
  auto a = *map->add_node(n);
  n.name = "b";
  auto b = *map->add_node(n);
  n.name = "c";
  auto c = *map->add_node(n);
  const auto ab = add_edge(*map, a, b, 10);
  const auto ba = add_edge(*map, b, a, 10);
  const auto bc = add_edge(*map, b, c, 1);
  const auto ca = add_edge(*map, c, a, 1);
  auto route = plan_cycle(*map, "a");
  ASSERT_TRUE(route.ok()) << route.error().message;
  EXPECT_EQ(route->edge_ids, (std::vector<std::string>{ab, bc, ca}));
  EXPECT_DOUBLE_EQ(route->length_m, 12.0);
  (void)ba;
  // a kind that is forbidden removes the cycle through it
  RouteCost forbid;
  forbid.kind_multiplier["feature_segment"] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(plan_cycle(*map, "a", forbid).ok());
  fs::remove_all(dir);
}

TEST(NavigationCore, PlanCycleFailsForNodeOnNoLoop) {
  auto dir = temp_map_dir("nocycle");
  auto map = MapStore::create(dir.string(), "nocycle");
  ASSERT_TRUE(map.ok());
  NodeRecord n;
  n.name = "a";
  auto a = *map->add_node(n);
  n.name = "b";
  auto b = *map->add_node(n);
  add_edge(*map, a, b, 3);
  auto route = plan_cycle(*map, "a");
  EXPECT_TRUE(fails_with(route, ErrorCode::not_found, key_only("a")));
  EXPECT_FALSE(plan_cycle(*map, "nope").ok());
  fs::remove_all(dir);
}

TEST(NavigationCore, CarriedDistanceProjectsTheOvershootOntoTheNextEdge) {
  const double q = std::numbers::pi / 2;
  EXPECT_NEAR(carried_distance_m(0.08, 0.0, 0.0, 0.5), 0.08, 1e-12);    // straight on: all of it
  EXPECT_NEAR(carried_distance_m(0.08, 0.02, 0.0, 0.5), 0.06, 1e-12);   // less the gap taught
  EXPECT_NEAR(carried_distance_m(0.08, 0.0, q, 0.5), 0.0, 1e-12);       // a right angle: sideways
  EXPECT_NEAR(carried_distance_m(0.08, 0.0, std::numbers::pi / 3, 0.5), 0.04, 1e-12);
  EXPECT_NEAR(carried_distance_m(0.01, 0.03, 0.0, 0.5), -0.02, 1e-12);  // stopped shorter than when taught
  EXPECT_DOUBLE_EQ(carried_distance_m(3.0, 0.0, 0.0, 0.5), 0.5);        // clamped
  EXPECT_DOUBLE_EQ(carried_distance_m(-3.0, 0.0, 0.0, 0.5), -0.5);
  EXPECT_DOUBLE_EQ(carried_distance_m(std::nan(""), 0.0, 0.0, 0.5), 0.0);
}

TEST(NavigationCore, DistanceScaleIsTheSlopeOfOdometryOverTaughtDistanceAtTheFixes) {
  DistanceScaleEstimator est({.min_baseline_m = 20.0, .max_deviation = 0.1});
  EXPECT_DOUBLE_EQ(est.scale(), 1.0);  // nothing seen yet
  // Replay odometry reads 2 % more than the teach run's; the fixes carry +-3 cm of error and the
  // mission started 1.5 m of odometry into the route (an offset, not a scale).
  const double noise[] = {0.03, -0.02, 0.01, -0.03, 0.02, 0.0};
  const double taught[] = {3.0, 11.0, 19.0, 30.0, 41.0, 60.0};
  est.add_fix(taught[0], 1.5 + 1.02 * taught[0] + noise[0]);
  est.add_fix(taught[1], 1.5 + 1.02 * taught[1] + noise[1]);
  EXPECT_DOUBLE_EQ(est.scale(), 1.0);  // 8 m apart: below the baseline, the fixes' errors would dominate
  for (int i = 2; i < 6; ++i) est.add_fix(taught[i], 1.5 + 1.02 * taught[i] + noise[i]);
  EXPECT_EQ(est.fixes(), 6);
  EXPECT_NEAR(est.scale(), 1.02, 0.002);
  est.add_fix(std::nan(""), 3.0);  // ignored
  EXPECT_EQ(est.fixes(), 6);

  DistanceScaleEstimator clamped({.min_baseline_m = 5.0, .max_deviation = 0.1});
  clamped.add_fix(0.0, 0.0);
  clamped.add_fix(10.0, 13.0);
  EXPECT_DOUBLE_EQ(clamped.scale(), 1.1);
  clamped.reset();
  EXPECT_EQ(clamped.fixes(), 0);
  EXPECT_DOUBLE_EQ(clamped.scale(), 1.0);

  EXPECT_TRUE(fails_with(DistanceScaleParams{.min_baseline_m = 0.0}.validate(), ErrorCode::out_of_range,
                         key_only("scale_min_baseline_m")));
  EXPECT_TRUE(fails_with(DistanceScaleParams{.max_deviation = 0.7}.validate(), ErrorCode::out_of_range,
                         key_only("scale_max_deviation")));
}

TEST(NavigationCore, PlanFromEdgeIsTheRestOfThatEdgeThenTheCheapestRoute) {
  auto dir = temp_map_dir("from_edge");
  auto map = MapStore::create(dir.string(), "from_edge");
  ASSERT_TRUE(map.ok()) << map.error().message;
  map->set_sync(false);
  NodeRecord n;
  n.name = "a";
  auto a = *map->add_node(n);
  n.name = "b";
  auto b = *map->add_node(n);
  n.name = "c";
  auto c = *map->add_node(n);
  const auto ab = add_edge(*map, a, b, 10);
  const auto bc = add_edge(*map, b, c, 4);
  const auto ca = add_edge(*map, c, a, 6);
  // From the middle of a->b back to a: the rest of a->b, then b->c->a.
  auto loop = plan_from_edge(*map, ab, "a");
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  EXPECT_EQ(loop->edge_ids, (std::vector<std::string>{ab, bc, ca}));
  EXPECT_DOUBLE_EQ(loop->length_m, 20.0);
  EXPECT_EQ(loop->from, a);
  // The goal is the edge's own end node: that edge alone.
  auto one = plan_from_edge(*map, bc, "c");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->edge_ids, (std::vector<std::string>{bc}));
  // Unknown edge or goal: errors with codes.
  auto unknown = plan_from_edge(*map, "nope", "a");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::not_found);
  EXPECT_FALSE(plan_from_edge(*map, ab, "nowhere").ok());
  fs::remove_all(dir);
}

TEST(NavigationCore, ProgressCheckpointIsWrittenWholeAndCleared) {
  auto dir = temp_map_dir("progress");
  fs::create_directories(dir);
  ASSERT_TRUE(write_progress(dir.string(), {"e3", 2.5, "n0"}).ok());
  ASSERT_TRUE(write_progress(dir.string(), {"e4", 0.25, "n0"}).ok());  // replaces, never appends
  std::ifstream in(dir / kProgressFile);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, format_progress({"e4", 0.25, "n0"}));
  EXPECT_NE(text.find("resume_edge: e4\nresume_distance_m: 0.250\nresume_goal: n0\n"), std::string::npos);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u) << "no temporary file is left";
  ASSERT_TRUE(clear_progress(dir.string()).ok());
  EXPECT_FALSE(fs::exists(dir / kProgressFile));
  EXPECT_TRUE(clear_progress(dir.string()).ok()) << "clearing twice is fine";
  EXPECT_FALSE(write_progress((dir / "missing" / "deeper").string(), {"e1", 0.0, "n0"}).ok());
  fs::remove_all(dir);
}
