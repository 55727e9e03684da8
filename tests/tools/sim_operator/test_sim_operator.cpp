#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "error_expect.hpp"
#include "experiment.hpp"
#include "operator_core.hpp"
#include "visnav/config.hpp"
#include "visnav_sim/robot.hpp"

using namespace visnav;
using namespace visnav::simop;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(ExperimentMetrics, AccuracyAndRepeatabilityFollowSeed000Eq18) {
  // Ends spread symmetrically around (1, 0); taught end at the origin.
  const std::vector<cv::Point2d> ends = {{1.0, 0.1}, {1.0, -0.1}, {1.2, 0.0}, {0.8, 0.0}};
  const auto m = accuracy_repeatability(ends, {0.0, 0.0});
  // ε_acc = sqrt(mean(|x_i|²)) = sqrt((1.01 + 1.01 + 1.44 + 0.64) / 4)
  EXPECT_NEAR(m.accuracy_m, std::sqrt((1.01 + 1.01 + 1.44 + 0.64) / 4.0), 1e-12);
  // μ = (1, 0): ε_rep = sqrt((0.01 + 0.01 + 0.04 + 0.04) / 4)
  EXPECT_NEAR(m.repeatability_m, std::sqrt(0.1 / 4.0), 1e-12);
  EXPECT_EQ(accuracy_repeatability({}, {0, 0}).accuracy_m, 0.0);
}

TEST(ScriptedOperator, MakeLegsMapsKindsClosesLoopAndRejectsBadInput) {
  const std::vector<cv::Point2d> pts = {{0, 0}, {4, 0}, {4, 3}};
  const std::vector<std::pair<std::string, std::string>> map = {{"feature", "feature_segment"}, {"path", "path_following"}};
  auto legs = make_legs(pts, {"feature", "path", "path"}, true, map, "");
  ASSERT_TRUE(legs.ok()) << legs.error().message;
  ASSERT_EQ(legs->size(), 3u);
  EXPECT_EQ((*legs)[0].kind, "feature_segment");
  EXPECT_EQ((*legs)[1].kind, "path_following");
  EXPECT_EQ((*legs)[2].to_m, cv::Point2d(0, 0));
  auto forced = make_legs(pts, {"feature", "path", "path"}, false, map, "feature_segment");
  ASSERT_TRUE(forced.ok());
  EXPECT_EQ(forced->size(), 2u);
  for (const auto& l : *forced) EXPECT_EQ(l.kind, "feature_segment");
  EXPECT_FALSE(make_legs(pts, {"feature", "swim", "path"}, false, map, "").ok());
  EXPECT_FALSE(make_legs({{0, 0}}, {"feature"}, false, map, "").ok());
  EXPECT_FALSE(make_legs({{0, 0}, {0, 0}}, {"feature", "feature"}, false, map, "").ok());
}

TEST(ScriptedOperator, DrivesASquareLegByLegTurningInPlaceBetweenLegs) {
  std::vector<OperatorLeg> legs;
  const std::vector<cv::Point2d> corners = {{0, 0}, {5, 0}, {5, 5}, {0, 5}};
  for (int i = 0; i < 4; ++i) legs.push_back({corners[i], corners[(i + 1) % 4], i % 2 ? "path_following" : "feature_segment"});
  ScriptedOperatorCore op(legs, OperatorParams{});
  Pose2D pose{0.0, 0.3, 0.2};  // starts off the first leg: the operator corrects it
  std::vector<std::string> kinds_seen;
  bool turned_in_place = false;
  int ticks = 0;
  for (; ticks < 20000; ++ticks) {
    const OperatorAction a = op.update(pose);
    if (a.done) break;
    if (a.primitive.empty()) {
      EXPECT_EQ(a.command.linear_mps, 0.0);  // never teaching while moving without a primitive
      if (a.command.angular_radps != 0.0) turned_in_place = true;
    } else if (kinds_seen.empty() || kinds_seen.back() != a.primitive) {
      kinds_seen.push_back(a.primitive);
    }
    const double dt = 0.05;
    pose.heading_rad += a.command.angular_radps * dt;
    pose.x_m += a.command.linear_mps * dt * std::cos(pose.heading_rad);
    pose.y_m += a.command.linear_mps * dt * std::sin(pose.heading_rad);
  }
  ASSERT_LT(ticks, 20000);
  EXPECT_TRUE(turned_in_place);
  EXPECT_EQ(kinds_seen, (std::vector<std::string>{"feature_segment", "path_following", "feature_segment", "path_following"}));
  EXPECT_NEAR(pose.x_m, 0.0, 0.1);  // back at the first corner
  EXPECT_NEAR(pose.y_m, 0.0, 0.1);
  EXPECT_TRUE(op.update(pose).done);
}

TEST(ScriptedOperator, ClosedRouteEndsFacingTheFirstLegAgain) {
  // Two legs out and back; on a closed route the operator, back at the start facing west,
  // turns in place (closing, no primitive) until it faces the first leg (east), then is done.
  const std::vector<OperatorLeg> legs = {{{0, 0}, {4, 0}, "feature_segment"}, {{4, 0}, {0, 0}, "feature_segment"}};
  ScriptedOperatorCore op(legs, OperatorParams{}, true);
  Pose2D pose{0.0, 0.0, 0.0};
  bool saw_closing = false;
  int ticks = 0;
  OperatorAction a;
  for (; ticks < 20000; ++ticks) {
    a = op.update(pose);
    if (a.done) break;
    if (a.closing) {
      saw_closing = true;
      EXPECT_TRUE(a.primitive.empty());
      EXPECT_EQ(a.command.linear_mps, 0.0);
    }
    const double dt = 0.05;
    pose.heading_rad += a.command.angular_radps * dt;
    pose.x_m += a.command.linear_mps * dt * std::cos(pose.heading_rad);
    pose.y_m += a.command.linear_mps * dt * std::sin(pose.heading_rad);
  }
  ASSERT_LT(ticks, 20000);
  EXPECT_TRUE(saw_closing);
  EXPECT_TRUE(a.closing);
  EXPECT_NEAR(std::remainder(pose.heading_rad, 2 * std::numbers::pi), 0.0, 0.02);
  EXPECT_NEAR(pose.x_m, 0.0, 0.1);
  // An open route never closes.
  ScriptedOperatorCore open_route(legs, OperatorParams{});
  Pose2D p2{0.0, 0.0, 0.0};
  for (int i = 0; i < 20000; ++i) {
    const OperatorAction b = open_route.update(p2);
    EXPECT_FALSE(b.closing);
    if (b.done) break;
    p2.heading_rad += b.command.angular_radps * 0.05;
    p2.x_m += b.command.linear_mps * 0.05 * std::cos(p2.heading_rad);
    p2.y_m += b.command.linear_mps * 0.05 * std::sin(p2.heading_rad);
  }
}

TEST(ScriptedOperator, ParamsValidation) {
  OperatorParams p;
  EXPECT_TRUE(p.validate().ok());
  p.speed_mps = 0.0;
  EXPECT_FALSE(p.validate().ok());
  p = OperatorParams{};
  p.min_turning_radius_m = -1.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("min_turning_radius_m")));
  p = OperatorParams{};
  p.arc_speed_mps = p.speed_mps + 0.1;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("arc_speed_mps")));
}

TEST(ScriptedOperator, CornerArcsTakeRTanHalfTurnOffEachLegAndTooShortLegsAreRefused) {
  // 6 x 4 rectangle, closed: four 90-degree corners, d = R tan(45 deg) = R on both sides of each.
  const std::vector<cv::Point2d> c = {{0, 0}, {6, 0}, {6, 4}, {0, 4}};
  std::vector<OperatorLeg> legs;
  for (int i = 0; i < 4; ++i) legs.push_back({c[i], c[(i + 1) % 4], "feature_segment"});
  auto arcs = leg_arcs(legs, true, 1.5);
  ASSERT_TRUE(arcs.ok()) << arcs.error().message;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(arcs->lead_in_m[i], 1.5, 1e-12);
    EXPECT_NEAR(arcs->lead_out_m[i], 1.5, 1e-12);
  }
  // Open: no arc into the first leg, none after the last; a 45-degree corner takes R tan(22.5).
  const std::vector<OperatorLeg> bend = {{{0, 0}, {5, 0}, "feature_segment"}, {{5, 0}, {9, 4}, "feature_segment"}};
  auto open = leg_arcs(bend, false, 2.0);
  ASSERT_TRUE(open.ok());
  EXPECT_EQ(open->lead_in_m[0], 0.0);
  EXPECT_NEAR(open->lead_out_m[0], 2.0 * std::tan(std::numbers::pi / 8), 1e-12);
  EXPECT_NEAR(open->lead_in_m[1], 2.0 * std::tan(std::numbers::pi / 8), 1e-12);
  EXPECT_EQ(open->lead_out_m[1], 0.0);
  // R = 2.5: the 4 m legs would need 5 m of arcs.
  EXPECT_TRUE(fails_with(leg_arcs(legs, true, 2.5), ErrorCode::out_of_range, key_only("min_turning_radius_m")));
  // A U-turn cannot be one arc at a node.
  const std::vector<OperatorLeg> back = {{{0, 0}, {4, 0}, "feature_segment"}, {{4, 0}, {0, 0}, "feature_segment"}};
  EXPECT_TRUE(fails_with(leg_arcs(back, true, 0.5), ErrorCode::out_of_range, key_only("min_turning_radius_m")));
  // R = 0: turning in place, nothing taken off.
  auto none = leg_arcs(legs, true, 0.0);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->lead_out_m[2], 0.0);
}

TEST(ScriptedOperator, TeachesACarLikeRobotRoundTheRectangleOnArcsWithinItsTurningRadius) {
  // The simulator's car-like kinematics (|w| <= |v| / R): the operator must get round every
  // corner, end each taught leg where its corner arc starts (R before the corner) and start the
  // next where it ends (R after), and close the loop at the first edge's start.
  const double radius_m = 1.0;
  const std::vector<cv::Point2d> c = {{0, 0}, {6, 0}, {6, 4}, {0, 4}};
  std::vector<OperatorLeg> legs;
  for (int i = 0; i < 4; ++i) legs.push_back({c[i], c[(i + 1) % 4], "feature_segment"});
  sim::RobotParams rp;
  rp.kinematics = "car_like";
  rp.min_turning_radius_m = radius_m;
  rp.start_pose = {0.0, 0.0, 0.0};
  ASSERT_TRUE(rp.validate().ok());
  sim::RobotCore robot(rp, Pose2D{0.0, 0.0, 0.0}, nullptr);
  OperatorParams params;
  params.min_turning_radius_m = radius_m;
  ScriptedOperatorCore op(legs, params, true);
  std::vector<cv::Point2d> edge_ends, edge_starts;
  std::string last = "?";
  bool in_place = false;
  OperatorAction a;
  int ticks = 0;
  for (; ticks < 4000; ++ticks) {
    const Pose2D pose = robot.ground_truth();
    a = op.update(pose);
    if (a.primitive != last) {
      (a.primitive.empty() ? edge_ends : edge_starts).push_back({pose.x_m, pose.y_m});
      last = a.primitive;
    }
    if (a.done) break;
    // The operator never asks for a curvature tighter than 1 / R, never turns on the spot.
    if (a.command.angular_radps != 0.0) {
      if (a.primitive.empty()) {
        EXPECT_LE(std::abs(a.command.angular_radps), a.command.linear_mps / radius_m + 1e-9);
      }
      if (a.command.linear_mps == 0.0) in_place = true;
    }
    robot.command(a.command);
    ASSERT_TRUE(robot.step(0.1).ok());
  }
  ASSERT_LT(ticks, 4000) << "the car-like teach stalled";
  EXPECT_FALSE(in_place);
  ASSERT_EQ(edge_starts.size(), 4u);
  ASSERT_EQ(edge_ends.size(), 5u);  // "?" -> "" at the first update, then one per leg
  // First edge starts R along the first leg (where the closing arc will end).
  EXPECT_NEAR(edge_starts[0].x, 1.0, 0.1);
  EXPECT_NEAR(edge_starts[0].y, 0.0, 0.05);
  // Each edge ends R before its corner (the node) and the next starts about R after it.
  const std::vector<cv::Point2d> expected_ends = {{5, 0}, {6, 3}, {1, 4}, {0, 1}};
  const std::vector<cv::Point2d> expected_starts = {{6, 1}, {5, 4}, {0, 3}};
  for (int i = 0; i < 4; ++i) EXPECT_LT(cv::norm(edge_ends[i + 1] - expected_ends[i]), 0.15) << "edge " << i;
  // (the arc's proportional tail, as FollowRoute's, ends it a little further on: < 0.35 m)
  for (int i = 0; i < 3; ++i) EXPECT_LT(cv::norm(edge_starts[i + 1] - expected_starts[i]), 0.35) << "edge " << i + 1;
  // Closed: the closing arc ends facing the first leg, near where the first edge started.
  const Pose2D end = robot.ground_truth();
  EXPECT_NEAR(std::remainder(end.heading_rad, 2 * std::numbers::pi), 0.0, 0.05);
  EXPECT_LT(cv::norm(cv::Point2d(end.x_m, end.y_m) - edge_starts[0]), 0.3);
}

TEST(ExperimentMetrics, SpreadIsMeanSampleSdAndWorst) {
  const Spread s = spread({0.1, 0.2, 0.3});
  EXPECT_NEAR(s.mean, 0.2, 1e-12);
  EXPECT_NEAR(s.sd, 0.1, 1e-12);  // sample sd
  EXPECT_EQ(s.worst, 0.3);
  EXPECT_EQ(s.count, 3);
  EXPECT_EQ(spread({}).count, 0);
  EXPECT_EQ(spread({0.5}).sd, 0.0);
}

TEST(ExperimentOptions, AppearancesAreKnownAndABadOneListsTheKnownOnes) {
  EXPECT_TRUE(appearance_overrides("same")->empty());
  ASSERT_TRUE(appearance_overrides("winter").ok());
  EXPECT_EQ(appearance_overrides("winter")->front(), "camera.params.season=winter");
  for (const char* name : {"autumn", "dusk", "low_sun", "overcast"}) EXPECT_TRUE(appearance_overrides(name).ok()) << name;
  auto bad = appearance_overrides("fog");
  EXPECT_TRUE(fails_with(bad, ErrorCode::out_of_range, key_only("fog")));
  EXPECT_NE(bad.error().message.find("winter"), std::string::npos) << bad.error().message;  // content: the choices
}

TEST(ExperimentOptions, IdealSwitchesEveryErrorModelOfTheExperimentConfigOff) {
  // Every override must name a key the experiment config's robot/camera accept, and loading the
  // shipped config with them must succeed (a renamed key would silently stop switching it off).
  auto config = load_run_config(std::string(VISNAV_SOURCE_DIR) + "/config/sim_experiment.yaml", ideal_overrides());
  ASSERT_TRUE(config.ok()) << config.error().message;
  for (const char* key : {"odom_scale_error_sd_pct", "odom_wheel_asymmetry_sd_pct", "slip_grass_pct"}) {
    const ConfigNode* v = config->robot.params.find(key);
    ASSERT_NE(v, nullptr) << key;
    EXPECT_EQ(v->scalar(), "0") << key;
  }
  const ConfigNode* noise = config->camera.params.find("noise_std");
  ASSERT_NE(noise, nullptr);
  EXPECT_EQ(noise->scalar(), "0");
}
