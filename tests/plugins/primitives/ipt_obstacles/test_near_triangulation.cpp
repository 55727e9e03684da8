// Longer-baseline triangulation of tracked corners (near_triangulation.hpp): the viewing ray of a
// pixel goes through the point projected there; two rays meet at the point; on frames ray-cast
// from a textured ground with a textured wall standing on it 3 m ahead, a robot driving 0.3 m
// towards it finds obstacle points on the wall and none on the bare ground.
#include <cmath>
#include <string>
#include <cstdint>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "value_noise.hpp"
#include "visnav/ipt_obstacles/back_off_look.hpp"
#include "visnav/ipt_obstacles/motion_watch.hpp"
#include "visnav/ipt_obstacles/near_triangulation.hpp"

namespace visnav::ipt {
namespace {

using visnav::test::fails_with;
using visnav::test::key_only;

using testing::value_noise;

/// A textured wall x = x_m, y_right_m <= y <= y_left_m, 0 <= z <= 1.5 (facing -x).
struct Wall {
  double x_m = 3.0, y_right_m = -0.6, y_left_m = 0.6;
};

/// Ray-cast frame: textured ground (z = 0), and with `wall` a textured wall (default: x = 3 m,
/// |y| <= 0.6), for the robot at x_m on the x axis heading +x.
cv::Mat render(const IptCamera& camera, double x_m, bool wall, const Wall& w = Wall{}, double ground_cell_m = 0.04) {
  cv::Mat img(camera.height_px, camera.width_px, CV_8UC1, cv::Scalar(128));
  const LensPose lens = lens_pose(camera, Pose2D{x_m, 0.0, 0.0});
  for (int v = 0; v < camera.height_px; ++v) {
    for (int u = 0; u < camera.width_px; ++u) {
      const cv::Vec3d d = NearTriangulation::ray(camera, lens, {static_cast<double>(u), static_cast<double>(v)});
      const cv::Vec3d o(lens.x_m, lens.y_m, camera.height_m);
      double best = 1e9, value = 200.0;  // sky
      if (d[2] < -1e-9) {
        const double t = -o[2] / d[2];
        const cv::Vec3d p = o + t * d;
        best = t;
        value = value_noise(p[0], p[1], ground_cell_m);
      }
      if (wall && d[0] > 1e-9) {
        const double t = (w.x_m - o[0]) / d[0];
        const cv::Vec3d p = o + t * d;
        if (t < best && p[1] >= w.y_right_m && p[1] <= w.y_left_m && p[2] >= 0.0 && p[2] <= 1.5)
          value = value_noise(p[1], p[2], 0.05);
      }
      img.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(value);
    }
  }
  return img;
}

TEST(NearTriangulation, TheRayOfAPixelPassesThroughThePointProjectedThere) {
  IptCamera camera;
  const LensPose lens = lens_pose(camera, Pose2D{1.0, 2.0, 0.7});
  for (const cv::Vec3d& p : {cv::Vec3d(3.0, 3.5, 0.0), cv::Vec3d(2.5, 2.2, 1.2), cv::Vec3d(4.0, 4.5, 0.4)}) {
    const auto px = project_point(camera, lens, p);
    ASSERT_TRUE(px.has_value());
    const cv::Vec3d d = NearTriangulation::ray(camera, lens, *px);
    const cv::Vec3d to = p - cv::Vec3d(lens.x_m, lens.y_m, camera.height_m);
    EXPECT_NEAR(cv::norm(d.cross(to / cv::norm(to))), 0.0, 1e-9);
    EXPECT_GT(d.dot(to), 0.0);
  }
}

TEST(NearTriangulation, TwoRaysMeetAtThePoint) {
  const cv::Vec3d p(3.0, 0.4, 1.1), a(0.0, 0.0, 0.5), b(0.3, 0.0, 0.5);
  double gap = 1.0;
  const auto hit = NearTriangulation::intersect(a, (p - a) / cv::norm(p - a), b, (p - b) / cv::norm(p - b), gap);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(cv::norm(*hit - p), 0.0, 1e-9);
  EXPECT_NEAR(gap, 0.0, 1e-9);
  // Parallel rays do not meet.
  EXPECT_FALSE(NearTriangulation::intersect(a, {1, 0, 0}, b + cv::Vec3d(0, 1, 0), {1, 0, 0}, gap).has_value());
}

std::vector<NearPoint> drive(bool wall) {
  IptCamera camera;
  auto made = NearTriangulation::create(camera, NearTriangulationParams{});
  EXPECT_TRUE(made.ok());
  std::vector<NearPoint> all;
  for (int k = 0; k <= 16; ++k) {  // 2 cm per frame, 0.32 m in all: one baseline
    const double x = 0.02 * k;
    auto points = made->observe(render(camera, x, wall), Pose2D{x, 0.0, 0.0});
    EXPECT_TRUE(points.ok());
    if (points) all.insert(all.end(), points->begin(), points->end());
  }
  return all;
}

TEST(NearTriangulation, FindsAWallAheadAndNothingOnBareGround) {
  const auto on_ground = drive(false);
  EXPECT_LE(on_ground.size(), 1U);
  const auto on_wall = drive(true);
  ASSERT_GE(on_wall.size(), 10U);
  int on_face = 0;
  for (const auto& p : on_wall)
    if (std::abs(p.ground_m.x - 3.0) < 0.25 && std::abs(p.ground_m.y) < 0.7) ++on_face;
  EXPECT_GE(on_face, static_cast<int>(0.9 * static_cast<double>(on_wall.size())));
}

// Back off and look (back_off_look.hpp): the robot stopped 0.6 m before a face 1.9 m wide that
// stands 0.4 m right of its heading (the campus van's rear; at 0.6 m the camera sees 0.7 m of it).
// Reversing 2 m with the triangulation fed to BackOffLook finds the face in the corridor at its
// distance and with its full lateral extent; on bare ground it finds nothing.
BackOffVerdict back_off(bool wall, BackOffLook& look, Pose2D& end) {
  IptCamera camera;
  auto made = NearTriangulation::create(camera, NearTriangulationParams{});
  EXPECT_TRUE(made.ok());
  const Wall van{0.6, -0.4 - 0.95, -0.4 + 0.95};
  Pose2D pose{};
  double odometer = 10.0;
  look.begin(pose, odometer);
  for (int k = 0; k < 200; ++k) {
    const BackOffLook::Step s = look.step(pose, odometer);
    if (s.done) break;
    EXPECT_LT(s.command.linear_mps, 0.0);
    auto points = made->observe(render(camera, pose.x_m, wall, van), pose);
    EXPECT_TRUE(points.ok());
    if (points) {
      std::vector<cv::Point2d> ground;
      for (const auto& p : *points) ground.push_back(p.ground_m);
      look.add_points(ground);
    }
    pose.x_m += s.command.linear_mps * 0.1;  // 10 Hz
    odometer += s.command.linear_mps * 0.1;
  }
  end = pose;
  return look.verdict(pose);
}

TEST(BackOffLook, FindsAFacesDistanceAndFullWidthAndNothingOnBareGround) {
  const BackOffLookParams params;
  ASSERT_TRUE(params.validate());
  BackOffLook look(params);
  Pose2D end;
  const BackOffVerdict v = back_off(true, look, end);
  EXPECT_NEAR(end.x_m, -2.0, 0.02);  // reversed its distance_m
  ASSERT_TRUE(v.found) << v.in_corridor << " in the corridor";
  EXPECT_NEAR(v.range_m, 0.6 - end.x_m, 0.2);
  // The face spans −1.35..0.55 m: the points reach both of its edges.
  EXPECT_NEAR(v.right_m, -1.35, 0.25);
  EXPECT_NEAR(v.left_m, 0.55, 0.25);
  BackOffLook bare(params);
  const BackOffVerdict none = back_off(false, bare, end);
  EXPECT_FALSE(none.found);
  EXPECT_LE(none.in_corridor, 1);
}

TEST(BackOffLook, TheExtentIsTheFacesNotTheClutterAtOtherDepths) {
  // Campus seed 3, loop 2: the van's rear 2.3 m ahead from 1.0 m right to 0.2 m left, and a
  // corner 1.2 m left 3.5 m ahead: with every point ahead the left edge was 1.2 m and the detour
  // took the right, where the van reached beyond the view.
  BackOffLookParams params;
  std::vector<cv::Point2d> pts;
  for (double l = -1.0; l <= 0.2 + 1e-9; l += 0.1) pts.emplace_back(2.3 + 0.05 * std::sin(7.0 * l), l);
  pts.emplace_back(3.5, 1.2);
  BackOffLook look(params);
  look.begin(Pose2D{}, 0.0);
  look.add_points(pts);
  BackOffVerdict v = look.verdict(Pose2D{});
  ASSERT_TRUE(v.found);
  EXPECT_NEAR(v.range_m, 2.3, 0.06);
  EXPECT_NEAR(v.left_m, 0.2, 1e-6);
  EXPECT_NEAR(v.right_m, -1.0, 1e-6);
  params.face_depth_m = 0.0;  // every point ahead, as before
  BackOffLook all(params);
  all.begin(Pose2D{}, 0.0);
  all.add_points(pts);
  v = all.verdict(Pose2D{});
  EXPECT_NEAR(v.left_m, 1.2, 1e-6);
}

// The back-off's trigger (change_shape, motion_watch.hpp): the drive watch's changed pixels
// (ReplayAvoiding's moving_stop_m watch: 0.8-2 m ahead, ±1.2 m, 4 x 80 px) while driving at
// 3 cm per frame. Stopping 0.6 m before a textured face (the campus van's rear, 0.4 m right of
// the heading) changes one compact region; a fine ground texture that aliases (gravel: cells of
// 6 mm, below a pixel's footprint at 1-2 m) with nothing standing changes scattered specks.
ChangeShape shape_when_driving(bool wall, double ground_cell_m, int& changed_px) {
  IptCamera camera;
  MotionWatchParams params;
  params.near_m = 0.8;
  params.far_m = 2.0;
  params.half_width_m = 1.2;
  params.min_changed_px = 320;
  auto watch = MotionWatch::create(camera, params);
  EXPECT_TRUE(watch.ok());
  const Wall van{1.5, -0.4 - 0.95, -0.4 + 0.95};
  const double step_m = 0.03;
  for (double x = 0.78; x <= 0.9 + 1e-9; x += step_m) {  // the face from 0.72 to 0.6 m ahead
    auto changed = watch->observe(render(camera, x, wall, van, ground_cell_m), Pose2D{step_m, 0.0, 0.0});
    EXPECT_TRUE(changed.ok());
    changed_px = changed && *changed ? **changed : 0;
  }
  cv::Mat labels, stats, centroids;
  return change_shape(watch->last_changed(), ChangeShapeParams{}, labels, stats, centroids);
}

std::string describe(const ChangeShape& s) {
  return std::to_string(s.changed_px) + " px in " + std::to_string(s.pieces) + " pieces (largest " +
         std::to_string(s.largest_px) + "), solid " + std::to_string(s.solid_px) + " (share " + std::to_string(s.share) + ")";
}

TEST(ChangeShape, AFaceCloseAheadIsSolidGroundShimmerIsSpecks) {
  int face_px = 0, shimmer_px = 0;
  const ChangeShape face = shape_when_driving(true, 0.04, face_px);
  EXPECT_GE(face_px, 320) << describe(face);  // the drive watch calls it motion
  EXPECT_TRUE(face.compact) << describe(face);
  const ChangeShape shimmer = shape_when_driving(false, 0.006, shimmer_px);
  EXPECT_GE(shimmer_px, 320) << describe(shimmer);  // as many changed pixels: the count alone stops the robot
  EXPECT_FALSE(shimmer.compact) << describe(shimmer);
  cv::Mat labels, stats, centroids;
  EXPECT_FALSE(change_shape(cv::Mat::zeros(240, 320, CV_8UC1), ChangeShapeParams{}, labels, stats, centroids).compact);
  ChangeShapeParams share;
  share.min_share = 1.5;
  EXPECT_TRUE(fails_with(share.validate(), ErrorCode::out_of_range, key_only("min_share")));
}

TEST(BackOffLook, ReversesHoldingTheHeadingAndStopsAfterItsDistance) {
  BackOffLookParams params;
  params.distance_m = 1.0;
  BackOffLook look(params);
  look.begin(Pose2D{0.0, 0.0, 3.0}, 5.0);
  const auto s = look.step(Pose2D{-0.1, 0.0, 3.1}, 4.9);  // 0.1 rad left of the held heading
  EXPECT_FALSE(s.done);
  EXPECT_DOUBLE_EQ(s.command.linear_mps, -params.speed_mps);
  EXPECT_NEAR(s.command.angular_radps, -0.1 * params.heading_gain_per_s, 1e-9);
  const auto seam = look.step(Pose2D{-0.2, 0.0, -3.1}, 4.8);  // across +-pi: a small right turn
  EXPECT_LT(seam.command.angular_radps, 0.0);
  EXPECT_GE(seam.command.angular_radps, -params.max_angular_radps);
  EXPECT_FALSE(look.step(Pose2D{}, 4.01).done);
  EXPECT_TRUE(look.step(Pose2D{}, 4.0).done);
  // Points behind the robot or beside the corridor do not make an obstacle; four in it do.
  BackOffLook along_x(BackOffLookParams{});
  along_x.begin(Pose2D{}, 0.0);
  const std::vector<cv::Point2d> beside{{1.0, 1.0}, {1.2, -1.1}, {-0.5, 0.0}, {2.0, 0.9}, {5.0, 0.0}};
  along_x.add_points(beside);
  EXPECT_FALSE(along_x.verdict(Pose2D{}).found);
  EXPECT_EQ(along_x.verdict(Pose2D{}).ahead, 3);
  const std::vector<cv::Point2d> in_corridor{{2.0, 0.3}, {2.1, 0.0}, {2.0, -0.4}, {2.2, 0.1}};
  along_x.add_points(in_corridor);
  const BackOffVerdict v = along_x.verdict(Pose2D{});
  EXPECT_TRUE(v.found);
  EXPECT_EQ(v.in_corridor, 4);
  EXPECT_DOUBLE_EQ(v.range_m, 2.1);
  // The extent: points within face_depth_m of the face's 2.1 m, beside the corridor too (the
  // one at 2.0 m, 0.9 m left), not the nearer ones at 1.0 and 1.2 m.
  EXPECT_DOUBLE_EQ(v.left_m, 0.9);
  EXPECT_DOUBLE_EQ(v.right_m, -0.4);
  BackOffLookParams bad;
  bad.distance_m = 0.0;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("distance_m")));
  bad = BackOffLookParams{};
  bad.face_depth_m = -0.5;
  EXPECT_TRUE(fails_with(bad.validate(), ErrorCode::out_of_range, key_only("face_depth_m")));
}

TEST(NearTriangulation, BadInputIsRejected) {
  NearTriangulationParams p;
  p.baseline_m = 0.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("baseline_m")));
  auto made = NearTriangulation::create(IptCamera{}, NearTriangulationParams{});
  ASSERT_TRUE(made.ok());
  EXPECT_FALSE(made->observe(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), Pose2D{}).ok());
}

}  // namespace
}  // namespace visnav::ipt
