// Route scripts: parsing with file:line errors, command scripts, operator-like pure pursuit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "visnav_sim/commands.hpp"
#include "visnav_sim/route.hpp"
#include "visnav_sim/world.hpp"
#include "error_expect.hpp"

namespace vs = visnav::sim;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

double distance_to_polyline(const cv::Point2d& p, const std::vector<cv::Point2d>& pts) {
  double best = 1e9;
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const cv::Point2d ab = pts[i + 1] - pts[i];
    const double t = std::clamp((p - pts[i]).dot(ab) / ab.dot(ab), 0.0, 1.0);
    best = std::min(best, cv::norm(p - (pts[i] + ab * t)));
  }
  return best;
}

vs::Route load(const char* name) {
  auto path = vs::resolve_route_path(name);
  EXPECT_TRUE(path.ok()) << path.error().message;
  auto r = vs::load_route(*path);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return *r;
}

}  // namespace

TEST(SimRoute, BadRouteFilesNameFileAndLine) {
  auto r = vs::parse_route("route:\n  commands:\n    - {distance_m: 2, v: 0.5, speed: 1}\n", "r.yaml");
  EXPECT_TRUE(fails_with(r, ErrorCode::unknown_key, At{"r.yaml", 3, "speed"}));
  r = vs::parse_route("route:\n  waypoints:\n    - {at: [0, 0], kind: teleport}\n    - {at: [1, 0]}\n", "r.yaml");
  EXPECT_TRUE(fails_with(r, ErrorCode::out_of_range, At{"r.yaml", 3, "kind"}));
  r = vs::parse_route("route:\n  commands:\n    - {distance_m: 2, duration_s: 1, v: 0.5}\n", "r.yaml");
  ASSERT_FALSE(r.ok());
}

TEST(SimRoute, CommandScriptDrivesOdometricDistance) {
  const vs::Route route = load("straight6m");
  vs::RobotParams p;
  p.odom_scale_error_pct = 2.0;  // the script stops on odometry, like a real script
  auto samples = vs::drive_route(route, p, 20.0, 120.0);
  ASSERT_TRUE(samples.ok()) << samples.error().message;
  // the first command ends on the first tick whose odometry (50 Hz) reached 6 m: 0.4 m/s * (50 ms tick + 20 ms odometry age)
  const auto end = std::find_if(samples->begin(), samples->end(), [](const auto& s) { return s.leg == 1; });
  ASSERT_NE(end, samples->end());
  EXPECT_NEAR(end->odometry.distance_m, 6.0, 0.05);
  // then the robot brakes (1 m/s^2 from 0.4 m/s: 8 cm); ground truth = odometry / 1.02
  const auto& last = samples->back();
  EXPECT_NEAR(last.odometry.distance_m, 6.1, 0.05);
  EXPECT_NEAR(last.ground_truth.x_m, last.odometry.distance_m / 1.02, 0.01);
  EXPECT_NEAR(last.ground_truth.y_m, 0.0, 1e-6);
}

TEST(SimRoute, PursuitFollowsTheLemniscateAndClosesTheLoop) {
  const vs::Route route = load("lemniscate");
  EXPECT_NEAR(route.waypoint_length_m(), 17.0, 0.2);
  auto samples = vs::drive_route(route, vs::RobotParams{}, 20.0, 300.0);
  ASSERT_TRUE(samples.ok()) << samples.error().message;
  std::vector<cv::Point2d> poly;
  for (const auto& w : route.waypoints) poly.push_back(w.position_m);
  poly.push_back(poly.front());
  double worst = 0.0;
  std::set<std::pair<double, double>> commands;
  for (const auto& s : *samples) {
    worst = std::max(worst, distance_to_polyline({s.ground_truth.x_m, s.ground_truth.y_m}, poly));
    commands.insert({s.command.linear_mps, s.command.angular_radps});
  }
  EXPECT_LT(worst, 0.25);
  const auto& last = samples->back();
  EXPECT_LT(std::hypot(last.ground_truth.x_m - poly.front().x, last.ground_truth.y_m - poly.front().y), 0.3);
  EXPECT_NEAR(last.odometry.distance_m, 17.0, 1.0);
  // operator-like: few distinct commands, far fewer than ticks
  EXPECT_LT(commands.size(), samples->size() / 4);
}

TEST(SimRoute, CampusRouteHasFeatureAndPathLegsAndIsAbout150m) {
  const vs::Route route = load("campus");
  EXPECT_NEAR(route.waypoint_length_m(), 150.0, 10.0);
  auto world_path = vs::resolve_world_path(route.world);
  ASSERT_TRUE(world_path.ok());
  vs::RobotParams p;
  p.world = *world_path;
  auto samples = vs::drive_route(route, p, 10.0, 1200.0);
  ASSERT_TRUE(samples.ok()) << samples.error().message;
  double path_m = 0.0, feature_m = 0.0;
  auto world = vs::load_world_cached(*world_path);
  ASSERT_TRUE(world.ok());
  int path_samples_on_path = 0, path_samples = 0;
  for (size_t i = 1; i < samples->size(); ++i) {
    const auto& s = (*samples)[i];
    const double d = s.odometry.distance_m - (*samples)[i - 1].odometry.distance_m;
    (s.kind == "path" ? path_m : feature_m) += d;
    if (s.kind == "path") {
      ++path_samples;
      path_samples_on_path += (*world)->ground_label_at(s.ground_truth.x_m, s.ground_truth.y_m) == vs::LabelClass::path;
    }
  }
  EXPECT_GT(path_m, 50.0);  // junctions, the road crossing and sharp corners are feature legs
  EXPECT_GT(feature_m, 50.0);
  EXPECT_GT(path_samples_on_path, path_samples * 95 / 100);  // path legs drive on the gravel
}
