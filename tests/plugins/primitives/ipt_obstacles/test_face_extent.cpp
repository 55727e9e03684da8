// The face's full lateral extent from two frames (face_extent.hpp) on ray-cast frames:
//  * the campus van's rear (1.9 m wide, its bulk 1.35 m to the robot's right, 0.55 m to its
//    left) seen 2.24 m ahead with only its corners 0.11 m right .. 0.45 m left triangulated (the
//    standing watch's points on campus seed 4): both edges found within 0.2 m, and the lane
//    detour given the extent takes the free (left) side where the seen points alone send it right;
//  * the mirrored placement: the extent grows to the left and the detour goes right;
//  * bare ground (nothing standing where the "seen" points were): the span does not grow;
//  * bad input is rejected with its code.
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "ray_cast_face.hpp"
#include "visnav/ipt_obstacles/face_extent.hpp"
#include "visnav/ipt_obstacles/lane_detour.hpp"

namespace visnav::ipt {
namespace {

using testing::Face;
using testing::render;

struct Seen {
  FaceExtent extent;
  double range_m = 0.0;
};

/// The robot `ahead_m` before the face's plane (x = face.x_m), the earlier frame 0.5 m back; the
/// points seen 2.24 m ahead.
Seen look(const std::optional<Face>& face, double seen_right_m, double seen_left_m, double ahead_m = 2.24) {
  const IptCamera camera;
  const double face_x = face ? face->x_m : 7.1;
  const Pose2D now{face_x - ahead_m, 0.0, 0.0}, earlier{face_x - ahead_m - 0.5, 0.0, 0.0};
  auto r = face_extent(camera, render(camera, earlier, face), earlier, render(camera, now, face), now, 2.24,
                       seen_right_m, seen_left_m, FaceExtentParams{});
  EXPECT_TRUE(r.ok()) << (r ? std::string() : r.error().message);
  return Seen{r ? *r : FaceExtent{}, 2.24};
}

/// The side (+1 left, −1 right) the lane detour takes first from the line's start with `points`.
int side_taken(const std::vector<cv::Point2d>& points, double start_x_m) {
  LaneDetour detour(LaneDetourParams{}, Pose2D{start_x_m, 0.0, 0.0});
  detour.add_points(points);
  const LaneDecision d = detour.decide(Pose2D{start_x_m, 0.0, 0.0});
  EXPECT_EQ(d.kind, LaneDecision::Kind::drive) << d.reason;
  return d.lane_m > 0.0 ? 1 : (d.lane_m < 0.0 ? -1 : 0);
}

std::vector<cv::Point2d> across(double x_m, double right_m, double left_m) {
  std::vector<cv::Point2d> p;
  for (double l = right_m; l <= left_m + 1e-9; l += 0.1) p.emplace_back(x_m, l);
  return p;
}

TEST(FaceExtent, APartlySeenFaceGetsItsFullWidthAndTheDetourTheFreeSide) {
  Face van;
  van.x_m = 7.1;
  van.y_right_m = -1.35;
  van.y_left_m = 0.55;
  const Seen s = look(van, -0.11, 0.45);
  std::printf("extent %.3f .. %.3f m at %.2f m (%d face, %d other columns)\n", s.extent.right_m, s.extent.left_m, s.extent.range_m,
              s.extent.face_columns, s.extent.other_columns);
  // The 60° camera sees 1.29 m to either side at 2.24 m: the right edge (−1.35 m) is just out
  // of view, so the face runs to the image's edge there.
  EXPECT_TRUE(s.extent.found);
  EXPECT_GE(s.extent.face_share(), 0.3);  // the avoiding trees' standing_min_face_share keeps it
  EXPECT_NEAR(s.extent.range_m, 2.24, 0.15);
  EXPECT_NEAR(s.extent.right_m, van.y_right_m, 0.2);
  EXPECT_NEAR(s.extent.left_m, van.y_left_m, 0.2);
  EXPECT_TRUE(s.extent.clipped_right);
  EXPECT_FALSE(s.extent.clipped_left);
  ASSERT_FALSE(s.extent.points.empty());
  EXPECT_NEAR(s.extent.points.front().y, s.extent.right_m, 1e-9);
  EXPECT_NEAR(s.extent.points.back().y, s.extent.left_m, 1e-9);
  EXPECT_NEAR(s.extent.points.front().x, van.x_m, 1e-9);
  // The detour from 2.24 m before the face: right with the seen corners (0.71 m to shift
  // against 1.05 m), left (the free side) with the extent.
  const double start_x = van.x_m - 2.24;
  EXPECT_EQ(side_taken(across(van.x_m, -0.11, 0.45), start_x), -1);
  EXPECT_EQ(side_taken(s.extent.points, start_x), 1);

  // Mirrored: the bulk to the left, the right part seen.
  Face mirrored = van;
  mirrored.y_right_m = -0.55;
  mirrored.y_left_m = 1.35;
  const Seen m = look(mirrored, -0.45, 0.11);
  std::printf("mirrored extent %.3f .. %.3f m\n", m.extent.right_m, m.extent.left_m);
  EXPECT_NEAR(m.extent.right_m, mirrored.y_right_m, 0.2);
  EXPECT_NEAR(m.extent.left_m, mirrored.y_left_m, 0.2);
  EXPECT_EQ(side_taken(across(mirrored.x_m, -0.45, 0.11), start_x), 1);
  EXPECT_EQ(side_taken(m.extent.points, start_x), -1);
}

// Campus seed 4: the watch's 6 corners put the face 2.24 m ahead, the van's rear stood 3.7 m
// ahead (its image spans 1.9 m at 3.7 m): the sweep finds the plane and the full width there.
TEST(FaceExtent, AFaceFartherThanItsSeenPointsIsFoundAtItsDistance) {
  Face van;
  van.x_m = 7.1;
  van.y_right_m = -1.35;
  van.y_left_m = 0.55;
  const Seen s = look(van, -0.11, 0.45, 3.7);
  std::printf("extent %.3f .. %.3f m at %.2f m\n", s.extent.right_m, s.extent.left_m, s.extent.range_m);
  EXPECT_TRUE(s.extent.found);
  EXPECT_GE(s.extent.face_share(), 0.3);
  EXPECT_NEAR(s.extent.range_m, 3.7, 0.2);
  EXPECT_NEAR(s.extent.right_m, van.y_right_m, 0.2);
  EXPECT_NEAR(s.extent.left_m, van.y_left_m, 0.2);
  ASSERT_FALSE(s.extent.points.empty());
  EXPECT_NEAR(s.extent.points.front().x, van.x_m, 0.2);
  // The seen corners alone send the detour right; the side for the seen span and the extent
  // together is the free one (left), and the detour takes it (the extent lies beyond its 3 m
  // lookahead: the side is set before the first decision).
  std::vector<cv::Point2d> points = across(van.x_m - 3.7 + 2.24, -0.11, 0.45);
  EXPECT_EQ(side_taken(points, van.x_m - 3.7), -1);
  EXPECT_EQ(side_past(-0.11, 0.45), -1);
  const int side = side_past(std::min(-0.11, s.extent.right_m), std::max(0.45, s.extent.left_m));
  EXPECT_EQ(side, 1);
  points.insert(points.end(), s.extent.points.begin(), s.extent.points.end());
  LaneDetour detour(LaneDetourParams{}, Pose2D{van.x_m - 3.7, 0.0, 0.0});
  detour.add_points(points);
  detour.prefer_side(side);
  const LaneDecision d = detour.decide(Pose2D{van.x_m - 3.7, 0.0, 0.0});
  EXPECT_EQ(d.kind, LaneDecision::Kind::drive) << d.reason;
  EXPECT_GT(d.lane_m, 0.0) << d.reason;
}

TEST(FaceExtent, NothingStandingDoesNotGrowTheSpan) {
  const Seen s = look(std::nullopt, -0.11, 0.45);
  std::printf("bare ground: %.3f .. %.3f m (%d face, %d other columns)\n", s.extent.right_m, s.extent.left_m,
              s.extent.face_columns, s.extent.other_columns);
  EXPECT_LE(s.extent.left_m, 0.45 + 0.15);
  EXPECT_GE(s.extent.right_m, -0.11 - 0.15);
  EXPECT_FALSE(s.extent.found);
  EXPECT_GT(s.extent.other_columns, 20);  // the ground behind the plane is seen as such
  EXPECT_LT(s.extent.face_share(), 0.3);  // a firing here is dropped by the avoiding trees' share
  EXPECT_NEAR(s.extent.range_m, 2.24, 1e-9);
}

TEST(FaceExtent, BadInputIsRejected) {
  const IptCamera camera;
  const cv::Mat img = render(camera, Pose2D{}, std::nullopt);
  const Pose2D pose{};
  EXPECT_TRUE(test::fails_with(face_extent(camera, img, pose, img, pose, 0.0, -0.1, 0.1, FaceExtentParams{}),
                               ErrorCode::out_of_range));
  EXPECT_TRUE(test::fails_with(face_extent(camera, img, pose, img, pose, 2.0, 0.3, 0.1, FaceExtentParams{}),
                               ErrorCode::inconsistent));
  EXPECT_TRUE(test::fails_with(face_extent(camera, cv::Mat(10, 10, CV_8UC1), pose, img, pose, 2.0, -0.1, 0.1,
                                           FaceExtentParams{}),
                               ErrorCode::invalid_value));
  FaceExtentParams bad;
  bad.max_height_m = 0.1;
  EXPECT_TRUE(test::fails_with(face_extent(camera, img, pose, img, pose, 2.0, -0.1, 0.1, bad), ErrorCode::inconsistent));
  bad = FaceExtentParams{};
  bad.max_ratio = 2.0;
  EXPECT_TRUE(test::fails_with(face_extent(camera, img, pose, img, pose, 2.0, -0.1, 0.1, bad), ErrorCode::out_of_range));
}

}  // namespace
}  // namespace visnav::ipt
