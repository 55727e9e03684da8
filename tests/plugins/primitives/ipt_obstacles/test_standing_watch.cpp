// The standing watch (standing_watch.hpp) on ray-cast frames fed through the longer-baseline
// triangulation while the robot drives at 2 cm per frame with a 2 % odometry scale error:
//  * a textured face 1.9 m wide standing across the path 0.6 m right of the robot's line (the
//    van_path van's rear, docs/obstacles.md "A van the path follower keeps the path up to"):
//    found at least 2.5 m before it, its distance within 0.3 m, both lateral edges within 0.3 m;
//  * bare textured ground driven straight and on bends of 40 and 8 m radius: never found;
//  * the window logic on hand points: one triangulation is not enough, points outside the
//    corridor do not fire it but count for the extent, a bunch narrower than min_width_m does not
//    fire, points age out after memory_m; bad params.
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "ray_cast_face.hpp"
#include "visnav/ipt_obstacles/near_triangulation.hpp"
#include "visnav/ipt_obstacles/standing_watch.hpp"

namespace visnav::ipt {
namespace {

using visnav::test::fails_with;
using visnav::test::key_only;

using testing::Face;
using testing::render;

struct Found {
  std::optional<StandingVerdict> verdict;
  Pose2D at;  // the robot's true pose when it fired
};

/// Drives `frames` frames of 2 cm from (start_x_m, 0) along +x (or on a left bend of `radius_m` > 0),
/// the odometry reading 2 % long; feeds every frame's triangulation to a StandingWatch; the
/// first verdict that fires.
Found drive(const std::optional<Face>& face, int frames, double radius_m = 0.0, double start_x_m = 0.0) {
  IptCamera camera;
  auto near = NearTriangulation::create(camera, StandingWatch::triangulation_params());
  EXPECT_TRUE(near.ok());
  StandingWatch watch(StandingWatchParams{});
  Pose2D truth{start_x_m, 0.0, 0.0}, odom{start_x_m, 0.0, 0.0};
  double odometer = 0.0;
  for (int k = 0; k < frames; ++k) {
    auto points = near->observe(render(camera, truth, face), odom);
    EXPECT_TRUE(points.ok());
    std::vector<cv::Point2d> ground;
    if (points)
      for (const auto& p : *points) ground.push_back(p.ground_m);
    StandingVerdict v = watch.add(ground, odom, odometer);
    if (v.found) return Found{v, truth};
    const double step = 0.02, turn = radius_m > 0.0 ? step / radius_m : 0.0;
    truth.x_m += step * std::cos(truth.heading_rad + 0.5 * turn);
    truth.y_m += step * std::sin(truth.heading_rad + 0.5 * turn);
    truth.heading_rad += turn;
    odom.x_m += 1.02 * step * std::cos(odom.heading_rad + 0.5 * turn);
    odom.y_m += 1.02 * step * std::sin(odom.heading_rad + 0.5 * turn);
    odom.heading_rad += turn;
    odometer += 1.02 * step;
  }
  return Found{std::nullopt, truth};
}

TEST(StandingWatch, FindsAFaceOnThePathEarlyWithItsDistanceAndWidth) {
  const Face van;
  // From 5.6 m before the face, up to 4 m driven.
  const Found f = drive(van, 200, 0.0, 1.5);
  ASSERT_TRUE(f.verdict.has_value()) << "not found by x = " << f.at.x_m;
  const double ahead_m = van.x_m - f.at.x_m;
  EXPECT_GE(ahead_m, 2.5) << "fired at x = " << f.at.x_m;
  // The odometry reads 2 % long, so its distance is compared with a tolerance.
  EXPECT_NEAR(f.verdict->range_m, ahead_m, 0.3);
  EXPECT_NEAR(f.verdict->right_m, van.y_right_m, 0.3);
  EXPECT_NEAR(f.verdict->left_m, van.y_left_m, 0.3);
  EXPECT_GE(f.verdict->batches, 2);
  EXPECT_GE(f.verdict->points.size(), static_cast<std::size_t>(f.verdict->in_face));
}

TEST(StandingWatch, NothingOnAClearPathStraightOrOnABend) {
  const Found straight = drive(std::nullopt, 80);
  EXPECT_FALSE(straight.verdict.has_value()) << "fired at x = " << straight.at.x_m << ", " << straight.verdict->in_face;
  // A bend the triangulation still runs on (0.015 rad per 0.6 m baseline), and a sharp one
  // (8 m radius: 0.075 rad per baseline, past max_rotation_rad).
  for (const double radius_m : {40.0, 8.0}) {
    const Found bend = drive(std::nullopt, 80, radius_m);
    EXPECT_GT(bend.at.heading_rad, 1.5 / radius_m);  // it did turn
    EXPECT_FALSE(bend.verdict.has_value()) << radius_m << " m: fired at x = " << bend.at.x_m;
  }
}

TEST(StandingWatch, NeedsSeveralTriangulationsAndSeparatesCorridorFromExtent) {
  StandingWatchParams params;
  params.min_points = 4;
  params.min_batches = 2;
  StandingWatch watch(params);
  const Pose2D pose{};
  // One triangulation: 4 corners 3 m ahead in the corridor, 2 more 1.2 m left beside it.
  const std::vector<cv::Point2d> first{{3.0, 0.1}, {3.1, -0.2}, {3.2, 0.3}, {3.05, 0.0}, {3.1, 1.2}, {3.0, 1.0}};
  StandingVerdict v = watch.add(first, pose, 0.0);
  EXPECT_FALSE(v.found);
  EXPECT_EQ(v.in_face, 4);
  EXPECT_EQ(v.batches, 1);
  // The next triangulation sees the face again: found, its extent includes the points beside.
  const std::vector<cv::Point2d> second{{3.0, -0.3}};
  v = watch.add(second, pose, 0.3);
  ASSERT_TRUE(v.found);
  EXPECT_EQ(v.in_face, 5);
  EXPECT_NEAR(v.range_m, 3.05, 1e-9);  // the median
  EXPECT_NEAR(v.left_m, 1.2, 1e-9);
  EXPECT_NEAR(v.right_m, -0.3, 1e-9);
  EXPECT_EQ(v.points.size(), 7U);
  // Points bunched within 0.2 m across (stray corners on the obstacle-free campus) are no face.
  StandingWatch narrow(params);
  const std::vector<cv::Point2d> bunch{{2.2, 0.15}, {2.3, 0.25}, {2.25, 0.2}};
  (void)narrow.add(bunch, pose, 0.0);
  v = narrow.add(bunch, pose, 0.6);
  EXPECT_EQ(v.in_face, 6);
  EXPECT_EQ(v.batches, 2);
  EXPECT_FALSE(v.found);
  // Scattered points (one per depth window) do not make a face.
  StandingWatch scattered(params);
  for (int k = 0; k < 6; ++k) {
    const std::vector<cv::Point2d> one{{1.0 + 0.5 * k, 0.0}};
    v = scattered.add(one, pose, 0.1 * k);
  }
  EXPECT_FALSE(v.found);
  // Points age out after memory_m of travel.
  v = watch.add({}, pose, 0.0 + params.memory_m + 0.01);
  EXPECT_EQ(v.in_face, 1);
  EXPECT_FALSE(v.found);
  watch.reset();
  EXPECT_EQ(watch.judge(pose).in_face, 0);
}

TEST(StandingWatch, OneTriangulationWithManyFacePointsFiresWhenAsked) {
  // Campus seed 9, loop 2: one triangulation put 11 corners on the van's rear 3.1 m ahead and the
  // follower's steering left no second straight baseline before contact.
  StandingWatchParams params;
  params.min_points = 6;
  params.min_batches = 2;
  const Pose2D pose{};
  std::vector<cv::Point2d> face;
  for (int k = 0; k < 11; ++k) face.emplace_back(3.0 + 0.03 * (k % 3), -0.4 + 0.08 * k);
  StandingWatch twice(params);
  StandingVerdict v = twice.add(face, pose, 0.0);
  EXPECT_EQ(v.in_face, 11);
  EXPECT_EQ(v.batches, 1);
  EXPECT_FALSE(v.found);  // the default: seen again from a second baseline
  params.one_batch_points = 10;
  StandingWatch once(params);
  v = once.add(face, pose, 0.0);
  EXPECT_TRUE(v.found);
  EXPECT_NEAR(v.range_m, 3.03, 0.031);
  // Fewer than one_batch_points from one triangulation still wait for the second.
  StandingWatch few(params);
  v = few.add(std::span<const cv::Point2d>(face).first(9), pose, 0.0);
  EXPECT_FALSE(v.found);
  // Many points bunched narrower than min_width_m (a post, a stray cluster) do not fire either.
  StandingWatch narrow(params);
  std::vector<cv::Point2d> bunch;
  for (int k = 0; k < 12; ++k) bunch.emplace_back(2.5 + 0.02 * k, 0.1 + 0.01 * k);
  v = narrow.add(bunch, pose, 0.0);
  EXPECT_EQ(v.in_face, 12);
  EXPECT_FALSE(v.found);
  StandingWatchParams bad = params;
  bad.one_batch_points = -1;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("one_batch_points")));
}

TEST(StandingWatch, BadParamsAreRejected) {
  StandingWatchParams bad;
  bad.min_points = 0;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("min_points")));
  bad = StandingWatchParams{};
  bad.depth_band_m = -1.0;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("depth_band_m")));
}

}  // namespace
}  // namespace visnav::ipt
