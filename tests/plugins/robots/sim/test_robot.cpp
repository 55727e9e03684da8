// Kinematics, limits, delay, watchdog and the odometry error model of the sim robot.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>

#include "visnav_sim/robot.hpp"
#include "visnav_sim/world.hpp"

namespace vs = visnav::sim;
using visnav::Pose2D;
using visnav::Twist;

namespace {

vs::RobotParams fast_params() {
  vs::RobotParams p;
  p.start_pose = {0, 0, 0};
  p.linear_accel_mps2 = 100;
  p.angular_accel_radps2 = 100;
  p.max_linear_mps = 3;
  p.max_angular_radps = 3;
  p.command_timeout_s = 0;  // no watchdog unless a test wants one
  return p;
}

void drive(vs::RobotCore& r, Twist cmd, double seconds, double dt = 0.05) {
  const int n = static_cast<int>(std::lround(seconds / dt));
  for (int i = 0; i < n; ++i) {
    r.command(cmd);
    ASSERT_TRUE(r.step(dt).ok());
  }
}

}  // namespace

TEST(SimRobot, DiffDriveCircleHasRadiusVOverW) {
  vs::RobotCore r(fast_params(), Pose2D{}, nullptr);
  // centre of the circle for v = 0.5, w = 0.25 from the origin heading +x: (0, 2)
  double max_err = 0.0;
  for (int i = 0; i < 500; ++i) {
    r.command({0.5, 0.25});
    ASSERT_TRUE(r.step(0.05).ok());
    const Pose2D p = r.ground_truth();
    max_err = std::max(max_err, std::abs(std::hypot(p.x_m, p.y_m - 2.0) - 2.0));
  }
  EXPECT_LT(max_err, 0.01);  // includes the 10 ms ramp up to speed
}

TEST(SimRobot, CarLikeRespectsMinimumTurningRadius) {
  auto p = fast_params();
  p.kinematics = "car_like";
  p.min_turning_radius_m = 2.0;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, {0.5, 1.0}, 2.0);  // asks for radius 0.5 m
  const double w = r.true_twist().angular_radps;
  EXPECT_NEAR(w, 0.25, 1e-9);  // = v / R_min
  // and cannot turn on the spot
  drive(r, {0.0, 1.0}, 1.0);
  EXPECT_NEAR(r.true_twist().angular_radps, 0.0, 1e-9);
}

TEST(SimRobot, TrackedSlipReducesYawButNotOdometryYaw) {
  auto p = fast_params();
  p.kinematics = "tracked";
  p.track_slip = 0.2;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, {0.0, 0.5}, 2.0);
  EXPECT_NEAR(r.ground_truth().heading_rad, 0.8, 0.02);  // 0.5 * 0.8 * 2 s
  EXPECT_NEAR(r.odometry().pose.heading_rad, 1.0, 0.02); // tracks report the commanded turn
}

TEST(SimRobot, AccelerationAndVelocityLimits) {
  auto p = fast_params();
  p.linear_accel_mps2 = 0.5;
  p.max_linear_mps = 0.8;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, {2.0, 0.0}, 1.0, 0.01);
  EXPECT_NEAR(r.true_twist().linear_mps, 0.5, 1e-6);
  EXPECT_NEAR(r.ground_truth().x_m, 0.25, 0.01);  // ½ a t²
  drive(r, {2.0, 0.0}, 2.0, 0.01);
  EXPECT_NEAR(r.true_twist().linear_mps, 0.8, 1e-9);  // clamped to max_linear_mps
}

TEST(SimRobot, ActuationDelay) {
  auto p = fast_params();
  p.actuation_delay_s = 0.3;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  r.command({1.0, 0.0});
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(r.step(0.05).ok());  // 0.25 s
  EXPECT_EQ(r.ground_truth().x_m, 0.0);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(r.step(0.05).ok());  // 0.45 s
  EXPECT_NEAR(r.ground_truth().x_m, 0.15, 0.02);
}

TEST(SimRobot, WatchdogStopsWithoutCommands) {
  auto p = fast_params();
  p.command_timeout_s = 0.5;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  r.command({1.0, 0.0});
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(r.step(0.05).ok());  // 1 s, no further commands
  const double x1 = r.ground_truth().x_m;
  EXPECT_NEAR(x1, 0.5, 0.03);
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(r.step(0.05).ok());
  EXPECT_DOUBLE_EQ(r.ground_truth().x_m, x1);
  EXPECT_EQ(r.true_twist().linear_mps, 0.0);
}

TEST(SimRobot, OdometryScaleErrorAndHeadingDrift) {
  auto p = fast_params();
  p.odom_scale_error_pct = 5.0;
  p.odom_heading_drift_degpm = 2.0;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, {1.0, 0.0}, 10.0, 0.02);
  EXPECT_NEAR(r.true_distance_m(), 10.0, 0.02);
  const visnav::Odometry o = r.odometry();
  EXPECT_NEAR(o.distance_m, 10.5, 0.03);
  EXPECT_NEAR(o.pose.heading_rad, 20.0 * CV_PI / 180.0, 0.01);
  EXPECT_NEAR(r.ground_truth().heading_rad, 0.0, 1e-9);
  EXPECT_NEAR(r.ground_truth().y_m, 0.0, 1e-9);
}

TEST(SimRobot, OdometryDistanceIsSignedAndNoiseIsSeeded) {
  auto p = fast_params();
  p.odom_distance_noise_m_per_sqrt_m = 0.01;
  p.odom_heading_noise_deg_per_sqrt_m = 0.5;
  vs::RobotCore a(p, Pose2D{}, nullptr), b(p, Pose2D{}, nullptr);
  drive(a, {-0.5, 0.0}, 4.0);
  drive(b, {-0.5, 0.0}, 4.0);
  EXPECT_NEAR(a.odometry().distance_m, -2.0, 0.1);
  EXPECT_EQ(a.odometry().pose.heading_rad, b.odometry().pose.heading_rad);
  p.seed = 2;
  vs::RobotCore c(p, Pose2D{}, nullptr);
  drive(c, {-0.5, 0.0}, 4.0);
  EXPECT_NE(a.odometry().pose.heading_rad, c.odometry().pose.heading_rad);
}

TEST(SimRobot, OdometryRate) {
  auto p = fast_params();
  p.odom_rate_hz = 5.0;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  std::set<double> stamps;
  for (int i = 0; i < 200; ++i) {  // 2 s at 100 Hz
    r.command({0.5, 0.0});
    ASSERT_TRUE(r.step(0.01).ok());
    stamps.insert(r.odometry().timestamp_s);
  }
  ASSERT_EQ(stamps.size(), 11u);  // the initial reading at 0, then 0.2, 0.4, ..., 2.0
  EXPECT_NEAR(*std::next(stamps.begin()), 0.2, 1e-6);
  EXPECT_NEAR(*stamps.rbegin(), 2.0, 1e-6);
  EXPECT_NEAR(r.odometry().twist.linear_mps, 0.5, 1e-6);
}

TEST(SimRobot, StartDisplacementAndPoseHistory) {
  vs::RobotParams p = fast_params();
  p.start_pose = {1.0, 2.0, 90.0};
  p.displacement_lateral_m = 0.5;      // to the left of a robot facing +y: -x
  p.displacement_longitudinal_m = 1.0;  // forward: +y
  p.displacement_heading_deg = 10.0;
  const Pose2D s = vs::resolve_start(p, nullptr);
  EXPECT_NEAR(s.x_m, 0.5, 1e-9);
  EXPECT_NEAR(s.y_m, 3.0, 1e-9);
  EXPECT_NEAR(s.heading_rad, 100.0 * CV_PI / 180.0, 1e-9);
  vs::RobotCore r(fast_params(), Pose2D{}, nullptr);
  drive(r, {1.0, 0.0}, 2.0, 0.1);
  EXPECT_NEAR(r.pose_at(1.0).x_m, 1.0, 0.02);
  EXPECT_FALSE(r.step(0.0).ok());
  EXPECT_FALSE(r.step(std::nan("")).ok());
}

TEST(SimRobot, PluginObjectIsASimulationControl) {
  vs::RobotParams p = fast_params();
  auto a = vs::SimRobot::create(p);
  ASSERT_TRUE(a.ok()) << a.error().message;
  visnav::SimulationControl* sim = (*a)->simulation();
  ASSERT_NE(sim, nullptr);
  ASSERT_TRUE((*a)->send_command({0.5, 0.0}).ok());
  ASSERT_TRUE(sim->step(1.0).ok());
  EXPECT_NEAR(sim->time_s(), 1.0, 1e-12);
  EXPECT_GT(sim->ground_truth_pose().x_m, 0.4);
  ASSERT_TRUE(sim->set_ground_truth_pose({5, 5, 0}).ok());
  EXPECT_EQ(sim->ground_truth_pose().x_m, 5);
}

// --- per-run error draws, wheel asymmetry, slip, collisions (issue 12) -------------------

TEST(SimRobotRunErrors, SeedsDifferSameSeedRepeatsAndSdZeroIsTheMean) {
  vs::RobotParams p = fast_params();
  p.odom_scale_error_pct = 1.0;
  p.odom_scale_error_sd_pct = 3.0;
  p.odom_wheel_asymmetry_sd_pct = 0.2;
  p.odom_heading_drift_sd_degpm = 0.1;
  p.seed = 101;
  const vs::RunErrors a = vs::draw_run_errors(p);
  const vs::RunErrors a2 = vs::draw_run_errors(p);
  p.seed = 102;
  const vs::RunErrors b = vs::draw_run_errors(p);
  EXPECT_EQ(a.scale_error_pct, a2.scale_error_pct);
  EXPECT_EQ(a.wheel_asymmetry_pct, a2.wheel_asymmetry_pct);
  EXPECT_NE(a.scale_error_pct, b.scale_error_pct);
  EXPECT_NE(a.wheel_asymmetry_pct, b.wheel_asymmetry_pct);
  // The draws follow the configured distribution: over many seeds mean ~1 %, sd ~3 %.
  double sum = 0, sum2 = 0;
  const int n = 4000;
  for (int s = 0; s < n; ++s) {
    p.seed = s;
    const double e = vs::draw_run_errors(p).scale_error_pct;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 1.0, 0.2);
  EXPECT_NEAR(sd, 3.0, 0.2);
  p.odom_scale_error_sd_pct = 0;
  p.odom_wheel_asymmetry_sd_pct = 0;
  p.odom_heading_drift_sd_degpm = 0;
  EXPECT_EQ(vs::draw_run_errors(p).scale_error_pct, 1.0);
  EXPECT_EQ(vs::draw_run_errors(p).wheel_asymmetry_pct, 0.0);
}

TEST(SimRobotRunErrors, ANewSeedOnReconfigureIsANewRunTeachAndReplayDoNotCancel) {
  vs::RobotParams p = fast_params();
  p.odom_scale_error_sd_pct = 3.0;
  p.seed = 1;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, Twist{1.0, 0.0}, 4.0);
  const double teach_ratio = r.odometry().distance_m / r.true_distance_m();
  p.seed = 2;
  r.set_params(p);
  const double d0 = r.odometry().distance_m, t0 = r.true_distance_m();
  drive(r, Twist{1.0, 0.0}, 4.0);
  const double replay_ratio = (r.odometry().distance_m - d0) / (r.true_distance_m() - t0);
  EXPECT_NEAR(teach_ratio, 1.0 + vs::draw_run_errors([&] { auto q = p; q.seed = 1; return q; }()).scale_error_pct / 100, 1e-3);
  EXPECT_NEAR(replay_ratio, 1.0 + r.run_errors().scale_error_pct / 100, 1e-3);
  // the two runs' odometry disagree, as a real robot's do from day to day
  EXPECT_GT(std::abs(teach_ratio - replay_ratio), 1e-3);
}

TEST(SimRobotRunErrors, WheelAsymmetryDriftsTheOdometricHeadingNotTheTrueOne) {
  vs::RobotParams p = fast_params();
  p.odom_wheel_asymmetry_pct = 0.4;  // 0.4 % over a 0.4 m track: 0.01 rad per metre
  p.track_width_m = 0.4;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  drive(r, Twist{1.0, 0.0}, 10.0);
  EXPECT_NEAR(r.ground_truth().heading_rad, 0.0, 1e-9);
  EXPECT_NEAR(r.odometry().pose.heading_rad, 0.1, 2e-3);  // 10 m x 0.01 rad/m, left turn read
}

namespace {
std::shared_ptr<const vs::World> box_world() {
  // A 10 x 10 m grass yard with a gravel path strip, one wall across x = 3 and a tree at (0, 3).
  const char* yaml = R"(
world:
  textures:
    grass: {procedural: noise, color: [90, 140, 60]}
    gravel: {procedural: noise, color: [150, 140, 120]}
    brick: {procedural: noise, color: [120, 60, 50]}
    tree: {procedural: tree, color: [40, 110, 40], size_m: 4.0, pixels: 64}
  default_ground: {texture: grass, class: grass}
  regions:
    - {name: strip, texture: gravel, class: path, polygon: [[-5, -6], [5, -6], [5, -5], [-5, -5]]}
  walls:
    - {name: east_wall, texture: brick, height_m: 2, polyline: [[3, -4], [3, 4]]}
    - {name: sign, texture: brick, base_m: 1.5, height_m: 2.5, polyline: [[-3, -4], [-3, 4]]}
  trees:
    - {name: oak, at: [0, 3], height_m: 5, width_m: 3, texture: tree}
)";
  auto w = vs::parse_world(yaml, "yard.yaml", ".");
  EXPECT_TRUE(w.ok()) << (w ? "" : w.error().message);
  return w ? *w : nullptr;
}
}  // namespace

TEST(SimRobotCollisions, AWallStopsTheRobotIsRecordedOnceAndTheRobotCanBackAway) {
  auto world = box_world();
  ASSERT_NE(world, nullptr);
  vs::RobotParams p = fast_params();
  p.body_radius_m = 0.25;
  vs::RobotCore r(p, Pose2D{0, 0, 0}, world);
  drive(r, Twist{1.0, 0.0}, 5.0);  // towards the wall at x = 3
  ASSERT_EQ(r.collisions().size(), 1u);
  EXPECT_EQ(r.collisions()[0].obstacle, "east_wall");
  EXPECT_NEAR(r.ground_truth().x_m, 2.75, 0.06);
  EXPECT_LE(r.ground_truth().x_m, 2.75 + 1e-9);
  EXPECT_EQ(r.true_twist().linear_mps, 0.0);
  const double odom_at_contact = r.odometry().distance_m;
  drive(r, Twist{1.0, 0.0}, 1.0);  // pushing on: blocked, no new record, the wheels do not turn
  EXPECT_EQ(r.collisions().size(), 1u);
  EXPECT_NEAR(r.odometry().distance_m, odom_at_contact, 0.06);
  drive(r, Twist{-0.5, 0.0}, 1.0);  // backing away is possible
  EXPECT_LT(r.ground_truth().x_m, 2.4);
  drive(r, Twist{1.0, 0.0}, 2.0);  // a second contact is a second collision
  EXPECT_EQ(r.collisions().size(), 2u);
}

TEST(SimRobotCollisions, TreesAreTrunksHighWallsArePassedUnderAndZeroRadiusIsOff) {
  auto world = box_world();
  ASSERT_NE(world, nullptr);
  vs::RobotParams p = fast_params();
  p.body_radius_m = 0.25;
  {
    vs::RobotCore r(p, Pose2D{0, 0, CV_PI / 2}, world);  // north, towards the oak at (0, 3)
    drive(r, Twist{1.0, 0.0}, 5.0);
    ASSERT_EQ(r.collisions().size(), 1u);
    EXPECT_EQ(r.collisions()[0].obstacle, "oak");
    EXPECT_NEAR(r.ground_truth().y_m, 3.0 - p.trunk_radius_m - p.body_radius_m, 0.06);
  }
  {
    vs::RobotCore r(p, Pose2D{0, 0, CV_PI}, world);  // west, under the sign (base 1.5 m)
    drive(r, Twist{1.0, 0.0}, 4.0);
    EXPECT_TRUE(r.collisions().empty());
    EXPECT_LT(r.ground_truth().x_m, -3.5);
  }
  {
    p.body_radius_m = 0.0;
    vs::RobotCore r(p, Pose2D{0, 0, 0}, world);
    drive(r, Twist{1.0, 0.0}, 5.0);
    EXPECT_TRUE(r.collisions().empty());
    EXPECT_GT(r.ground_truth().x_m, 4.0);
  }
}

TEST(SimRobotSlip, OnGrassTheBodyMovesLessThanTheOdometryReads) {
  auto world = box_world();
  ASSERT_NE(world, nullptr);
  vs::RobotParams p = fast_params();
  p.slip_grass_pct = 10;
  p.slip_path_pct = 2;
  vs::RobotCore r(p, Pose2D{-4, 0, 0}, world);
  drive(r, Twist{1.0, 0.0}, 2.0);
  EXPECT_NEAR(r.true_distance_m() / r.odometry().distance_m, 0.90, 0.01);
  vs::RobotCore q(p, Pose2D{-4, -5.5, 0}, world);  // on the gravel strip
  drive(q, Twist{1.0, 0.0}, 2.0);
  EXPECT_NEAR(q.true_distance_m() / q.odometry().distance_m, 0.98, 0.01);
}

// Seed 002's platforms include computers that froze for seconds: a freeze is simulated time
// passing inside one step, with the robot running on its last command until the watchdog stops it.
TEST(SimRobotFreezes, AFreezeJumpsTimeAndTheWatchdogStopsTheRobotMeanwhile) {
  auto p = fast_params();
  p.command_timeout_s = 0.5;
  p.odom_distance_noise_m_per_sqrt_m = 0.01;
  p.freeze_rate_per_min = 6.0;  // about one freeze per 10 s of driving
  p.freeze_min_s = 2.0;
  p.freeze_max_s = 2.5;
  vs::RobotCore r(p, Pose2D{}, nullptr);
  int steps = 0;
  double longest_jump_s = 0.0, moved_in_longest_m = 0.0;
  while (r.time_s() < 60.0) {
    r.command({1.0, 0.0});
    const double t0 = r.time_s(), x0 = r.ground_truth().x_m;
    ASSERT_TRUE(r.step(0.05).ok());
    ++steps;
    if (r.time_s() - t0 > longest_jump_s) {
      longest_jump_s = r.time_s() - t0;
      moved_in_longest_m = r.ground_truth().x_m - x0;
    }
  }
  ASSERT_GE(r.freeze_count(), 2);
  EXPECT_LE(r.freeze_count(), 15);
  EXPECT_NEAR(r.time_s(), steps * 0.05 + r.frozen_s(), 1e-6);
  EXPECT_GE(longest_jump_s, 2.05 - 1e-9);
  EXPECT_LE(longest_jump_s, 2.55 + 1e-9);
  // 1 m/s: the command runs out after 0.5 s, then the robot stops (no acceleration limit here).
  EXPECT_NEAR(moved_in_longest_m, 0.55, 0.06);
  EXPECT_EQ(r.true_twist().linear_mps, 1.0);  // commands after the freeze drive it again

  // The same seed repeats the freezes; with the rate at 0 there are none.
  vs::RobotCore again(p, Pose2D{}, nullptr);
  while (again.time_s() < 60.0) {
    again.command({1.0, 0.0});
    ASSERT_TRUE(again.step(0.05).ok());
  }
  EXPECT_EQ(again.freeze_count(), r.freeze_count());
  EXPECT_DOUBLE_EQ(again.frozen_s(), r.frozen_s());
  auto calm = p;
  calm.freeze_rate_per_min = 0.0;
  vs::RobotCore c(calm, Pose2D{}, nullptr);
  drive(c, {1.0, 0.0}, 60.0);
  EXPECT_EQ(c.freeze_count(), 0);
  EXPECT_NEAR(c.time_s(), 60.0, 1e-6);
}

TEST(SimRobotFreezes, AMaximumBelowTheMinimumIsRejected) {
  auto p = fast_params();
  p.freeze_min_s = 3.0;
  p.freeze_max_s = 1.0;
  const auto st = p.validate();
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, visnav::ErrorCode::inconsistent);
  EXPECT_EQ(st.error().where.key, "freeze_max_s");
}
