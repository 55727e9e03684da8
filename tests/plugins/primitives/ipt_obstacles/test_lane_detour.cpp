// The replay's lane detour (lane_detour.hpp) in a kinematic closed loop on hand-placed obstacle
// points, and the two contact-point repairs it relies on (profiles.hpp: ranges cut to the
// triangulated feet, spans between the borders of one obstacle).
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "visnav/ipt_obstacles/lane_detour.hpp"
#include "visnav/ipt_obstacles/profiles.hpp"

namespace visnav::ipt {
namespace {

/// One 0.1 s step of the kinematic robot the detour tests drive: turning towards `heading_rad`
/// (robot frame) at most 0.6 rad/s, forward at 0.2 m/s scaled by its cosine, standing when it
/// points more than 1 rad off or the decision holds the forward travel (as ReplayAvoiding).
void drive_towards(Pose2D& pose, double heading_rad, bool hold_forward = false) {
  const double w = std::clamp(1.5 * heading_rad, -0.6, 0.6);
  const double v = hold_forward || std::fabs(heading_rad) > 1.0 ? 0.0 : 0.2 * std::max(0.0, std::cos(heading_rad));
  pose.heading_rad += w * 0.1;
  pose.x_m += v * 0.1 * std::cos(pose.heading_rad);
  pose.y_m += v * 0.1 * std::sin(pose.heading_rad);
}

struct Box {  // axis-aligned footprint
  double x0, x1, y0, y1;
  [[nodiscard]] double distance(double x, double y) const {
    const double dx = std::max({x0 - x, 0.0, x - x1}), dy = std::max({y0 - y, 0.0, y - y1});
    return std::hypot(dx, dy);
  }
};

struct LoopResult {
  LaneDecision last;
  double min_clearance_m = 1e9;
  int cycles = 0;
};

/// Unicycle at 10 Hz, 0.2 m/s, ω = 1.5·heading limited to 0.6 rad/s (ReplayAvoiding's defaults)
/// from the origin along +x; `seen` are the points the camera gave (only the van's rear face).
LoopResult drive(LaneDetourParams params, const std::vector<cv::Point2d>& seen, const Box& van) {
  Pose2D pose{};
  LaneDetour detour(params, pose);
  detour.add_points(seen);
  LoopResult r;
  for (; r.cycles < 2000; ++r.cycles) {
    r.last = detour.decide(pose);
    if (r.last.kind != LaneDecision::Kind::drive) break;
    drive_towards(pose, r.last.heading_rad, r.last.hold_forward);
    r.min_clearance_m = std::min(r.min_clearance_m, van.distance(pose.x_m, pose.y_m));
  }
  return r;
}

/// A van 4.8 m long, 1.9 m wide, its rear 2 m ahead, 0.2 m left of the line; only its rear
/// face is seen (what the IPT gives: the two corners and the span between them).
const Box kVan{2.0, 6.8, -0.75, 1.15};
std::vector<cv::Point2d> rear_face() {
  std::vector<cv::Point2d> pts;
  for (double y = kVan.y0; y <= kVan.y1 + 1e-9; y += 0.15) pts.emplace_back(kVan.x0, y);
  return pts;
}

TEST(LaneDetour, PassesAVanSeenOnlyFromBehindAndReturnsToTheLine) {
  const LoopResult r = drive(LaneDetourParams{}, rear_face(), kVan);
  ASSERT_EQ(r.last.kind, LaneDecision::Kind::done) << r.last.reason;
  EXPECT_GT(r.min_clearance_m, 0.25 + 0.05);  // body 0.25 m; the turn-out cuts the corner (0.34 m measured)
  EXPECT_NEAR(r.last.l_m, 0.0, 0.1);
  EXPECT_GT(r.last.s_m, kVan.x1);  // back on the line only past the van's (unseen) front
}

TEST(LaneDetour, PassesOnTheSideNearerTheLine) {
  // The van sits 0.2 m left: its right side needs the smaller offset.
  LaneDetour detour(LaneDetourParams{}, Pose2D{});
  detour.add_points(rear_face());
  const LaneDecision d = detour.decide(Pose2D{});
  ASSERT_EQ(d.kind, LaneDecision::Kind::drive);
  EXPECT_NEAR(d.lane_m, kVan.y0 - 0.6, 0.051);
  EXPECT_LT(d.heading_rad, 0.0);
}

TEST(LaneDetour, AShortUnseenLengthTurnsBackIntoTheVansSide) {
  // Why behind_m is long: with 0.8 m the robot returns while beside the van.
  LaneDetourParams p;
  p.behind_m = 0.8;
  const LoopResult r = drive(p, rear_face(), kVan);
  EXPECT_LT(r.min_clearance_m, 0.25);
}

TEST(LaneDetour, EndsAtTheLinesEndBackOnTheLine) {
  LaneDetourParams p;
  p.end_s_m = 8.0;  // the edge ends 5 m past a short box: the point holds only until 8 − return_m
  p.return_m = 3.0;  // (the default 2 m leaves it 0.25 m beside the line at the end)
  const LoopResult r = drive(p, rear_face(), Box{2.0, 3.0, -0.75, 1.15});
  ASSERT_EQ(r.last.kind, LaneDecision::Kind::done) << r.last.reason;
  EXPECT_LE(r.last.s_m, 8.0 + 0.03);
  EXPECT_NEAR(r.last.l_m, 0.0, 0.2);
}

/// The outline points of `box` (every 0.15 m) a camera on the robot sees from `pose`: on a face
/// turned towards it, 0.3-4 m away, within ±30° of the heading (a 60° view). Beside the box its
/// side is out of view: the camera looks ahead.
std::vector<cv::Point2d> seen_from(const Pose2D& pose, const Box& box) {
  std::vector<cv::Point2d> out;
  auto look = [&](double x, double y, bool facing) {
    const double dx = x - pose.x_m, dy = y - pose.y_m, range = std::hypot(dx, dy);
    const double bearing = std::remainder(std::atan2(dy, dx) - pose.heading_rad, 2.0 * CV_PI);
    if (facing && range >= 0.3 && range <= 4.0 && std::fabs(bearing) <= CV_PI / 6.0) out.emplace_back(x, y);
  };
  for (double x = box.x0; x <= box.x1 + 1e-9; x += 0.15) {
    look(x, box.y0, pose.y_m < box.y0);
    look(x, box.y1, pose.y_m > box.y1);
  }
  for (double y = box.y0; y <= box.y1 + 1e-9; y += 0.15) {
    look(box.x0, y, pose.x_m < box.x0);
    look(box.x1, y, pose.x_m > box.x1);
  }
  return out;
}

struct PassResult {
  LaneDecision last;
  double min_beside_m = 1e9;  ///< the body centre's least distance to the box 1 m past its rear (after the turn-out)
  std::size_t points = 0;
};

/// As drive(), but the detour gets the points the camera sees each cycle.
PassResult pass_seeing(LaneDetourParams params, const Box& box) {
  Pose2D pose{};
  LaneDetour detour(params, pose);
  PassResult r;
  for (int cycle = 0; cycle < 3000; ++cycle) {
    detour.add_points(seen_from(pose, box));
    r.last = detour.decide(pose);
    if (r.last.kind != LaneDecision::Kind::drive) break;
    drive_towards(pose, r.last.heading_rad, r.last.hold_forward);
    if (pose.x_m > box.x0 + 1.0) r.min_beside_m = std::min(r.min_beside_m, box.distance(pose.x_m, pose.y_m));
  }
  r.points = detour.point_count();
  return r;
}

TEST(LaneDetour, ReturnsOnlyWithTheBodyPastTheFarEndItSawBeforeTheBox) {
  // Campus seed 5 (docs/obstacles.md "What still fails"): a 5 m box, its rear 2 m ahead, 0.2 m
  // left of the line; the edge ends 0.5 m past its far end, so behind_m is cut by the line's end
  // (return_m) to 3.5 m from the rear. The camera sees the rear and, turning out, the near side
  // up to the far corner; beside the box it sees nothing of it. The return must keep the body
  // (0.25 m) and most of the clearance (0.35 m) off the side and the far corner: the points of
  // the far end hold the lane until the body is past them (min_behind_m, and never less than
  // the body radius + clearance, whatever the line's end says).
  const Box box{2.0, 7.0, -0.75, 1.15};
  LaneDetourParams p;
  p.end_s_m = 7.5;
  const PassResult r = pass_seeing(p, box);
  ASSERT_GT(r.points, 20U);
  ASSERT_EQ(r.last.kind, LaneDecision::Kind::done) << r.last.reason;
  EXPECT_GT(r.min_beside_m, 0.25 + 0.3) << r.min_beside_m;
  EXPECT_GT(r.last.s_m, box.x1);  // ended at the line's end, past the box, not beside it
}

/// As drive(), but the odometry's heading drifts from the truth by `drift_rad_per_m` per metre
/// driven (towards the box): the detour steers on the odometry, the body moves on the truth.
/// Returns the body centre's least true distance to the box once 1 m past its rear.
double pass_drifting(LaneDetourParams params, const Box& box, double drift_rad_per_m) {
  Pose2D odom{}, truth{};
  LaneDetour detour(params, odom);
  std::vector<cv::Point2d> rear;
  for (double y = box.y0; y <= box.y1 + 1e-9; y += 0.15) rear.emplace_back(box.x0, y);
  detour.add_points(rear);
  double least = 1e9;
  for (int cycle = 0; cycle < 3000; ++cycle) {
    const LaneDecision d = detour.decide(odom);
    if (d.kind != LaneDecision::Kind::drive) break;
    const double w = std::clamp(1.5 * d.heading_rad, -0.6, 0.6);
    const double v = std::fabs(d.heading_rad) > 1.0 ? 0.0 : 0.2 * std::max(0.0, std::cos(d.heading_rad));
    odom.heading_rad += w * 0.1;
    odom.x_m += v * 0.1 * std::cos(odom.heading_rad);
    odom.y_m += v * 0.1 * std::sin(odom.heading_rad);
    truth.heading_rad += w * 0.1 + drift_rad_per_m * v * 0.1;
    truth.x_m += v * 0.1 * std::cos(truth.heading_rad);
    truth.y_m += v * 0.1 * std::sin(truth.heading_rad);
    if (truth.x_m > box.x0 + 1.0) least = std::min(least, box.distance(truth.x_m, truth.y_m));
  }
  return least;
}

TEST(LaneDetour, KeepsClearOfAnUnseenSideWhileTheOdometryDrifts) {
  // Campus seed 5, loop 2 (docs/obstacles.md "What still fails"): only the van's rear face seen,
  // the pass beside its 5 m side blind; the odometry's heading drifted 0.07 rad over 6.8 m
  // (0.01 rad/m) towards the van, the robot's true offset 0.34 m nearer its side than its
  // odometry said, and the body touched the side near its far end while still in its lane. This
  // kinematic loop has no scale error: 0.014 rad/m puts the body at the side without the drift
  // margin (0.22 m from it, measured) and 0.46 m off it with the default margin.
  const Box van{2.0, 7.0, -0.75, 1.15};
  const double with = pass_drifting(LaneDetourParams{}, van, 0.014);
  EXPECT_GT(with, 0.25 + 0.1) << with;  // body 0.25 m
  LaneDetourParams off;
  off.max_drift_m = 0.0;
  const double without = pass_drifting(off, van, 0.014);
  EXPECT_LT(without, 0.25 + 0.05) << without;  // without the drift margin: at the side
  // No drift: the margin costs nothing but width.
  const double straight = pass_drifting(LaneDetourParams{}, van, 0.0);
  EXPECT_GT(straight, 0.25 + 0.3) << straight;
}

TEST(LaneDetour, NeverDrivesTheBodyIntoAKnownPoint) {
  // Campus seed 3 (session 16): the detour began 1.2 m in front of a face it saw whole, its lane
  // 0.9 m left of the line; pursuing a point 1.2 m ahead the robot was still turning out when
  // its front reached the face. The guard holds the forward travel and turns in place instead.
  const Box face{1.2, 1.4, -1.0, 0.35};
  std::vector<cv::Point2d> seen;
  for (double y = face.y0; y <= face.y1 + 1e-9; y += 0.05) seen.emplace_back(face.x0, y);
  LaneDetourParams params;
  params.clearance_m = 0.3;
  params.behind_m = 0.5;
  params.guard_reach_m = 0.0;
  const LoopResult unguarded = drive(params, seen, face);
  EXPECT_LT(unguarded.min_clearance_m, params.body_radius_m) << "the geometry must collide without the guard";
  params.guard_reach_m = 0.3;
  const LoopResult guarded = drive(params, seen, face);
  ASSERT_EQ(guarded.last.kind, LaneDecision::Kind::done) << guarded.last.reason;
  EXPECT_GT(guarded.min_clearance_m, params.body_radius_m);
  EXPECT_GT(guarded.last.s_m, face.x1);
  // Points in every direction within guard_max_turn_rad: blocked with the reason, not driven into.
  LaneDetour boxed(LaneDetourParams{}, Pose2D{});
  std::vector<cv::Point2d> ring;
  for (double a = -1.7; a <= 1.7; a += 0.05) ring.emplace_back(0.4 * std::cos(a), 0.4 * std::sin(a));
  boxed.add_points(ring);
  const LaneDecision d = boxed.decide(Pose2D{});
  EXPECT_EQ(d.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(d.reason.find("in the body's way"), std::string::npos) << d.reason;
}

TEST(LaneDetour, NoFreeLaneIsBlockedWithAReason) {
  std::vector<cv::Point2d> wall;
  for (double y = -3.0; y <= 3.0; y += 0.2) wall.emplace_back(1.5, y);
  LaneDetour detour(LaneDetourParams{}, Pose2D{});
  detour.add_points(wall);
  const LaneDecision d = detour.decide(Pose2D{});
  EXPECT_EQ(d.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(d.reason.find("no free lane"), std::string::npos);
}

// The van_path case (docs/obstacles.md "A van hiding the path", van 0.4 m left): the first
// points leave the left side nearer, the detour turns left; then points close the left up to
// max_offset_m. Close to the obstacle the detour keeps its side and is blocked with the reason
// (commit_m); without it, it swings across the obstacle's face to the right.
LaneDecision after_left_closes(double commit_m) {
  LaneDetourParams p;
  p.commit_m = commit_m;
  p.max_recoveries = 0;  // the session 13 behaviour: blocked (the recovery: tests below)
  LaneDetour detour(p, Pose2D{});
  std::vector<cv::Point2d> first;
  for (double y = -0.55; y <= 0.2 + 1e-9; y += 0.15) first.emplace_back(2.0, y);
  detour.add_points(first);
  const LaneDecision start = detour.decide(Pose2D{});
  EXPECT_EQ(start.kind, LaneDecision::Kind::drive);
  EXPECT_GT(start.lane_m, 0.0);  // left chosen
  std::vector<cv::Point2d> left;
  for (double y = 0.2; y <= 3.0; y += 0.15) left.emplace_back(2.3, y);
  detour.add_points(left);
  return detour.decide(Pose2D{0.6, 0.3, 0.4});
}

TEST(LaneDetour, KeepsItsSideCloseToTheObstacleAndIsBlockedWithTheReason) {
  const LaneDecision kept = after_left_closes(LaneDetourParams{}.commit_m);
  EXPECT_EQ(kept.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(kept.reason.find("the left side closes"), std::string::npos) << kept.reason;
  const LaneDecision swung = after_left_closes(0.0);
  EXPECT_EQ(swung.kind, LaneDecision::Kind::drive);
  EXPECT_LT(swung.lane_m, 0.0);  // across to the right, 1.7 m before the points
  // Far from the obstacle (farther than commit_m before it: 2.5 m) the other side is still taken.
  LaneDetourParams p;
  LaneDetour far(p, Pose2D{});
  std::vector<cv::Point2d> face;
  for (double y = -0.55; y <= 0.2 + 1e-9; y += 0.15) face.emplace_back(6.0, y);
  far.add_points(face);
  ASSERT_GT(far.decide(Pose2D{3.5, 0.0, 0.0}).lane_m, 0.0);
  std::vector<cv::Point2d> wall;
  for (double y = 0.2; y <= 3.0; y += 0.15) wall.emplace_back(6.3, y);
  far.add_points(wall);
  EXPECT_EQ(far.decide(Pose2D{3.5, 0.0, 0.0}).kind, LaneDecision::Kind::drive);
  EXPECT_LT(far.decide(Pose2D{3.5, 0.0, 0.0}).lane_m, 0.0);
}

// Recovery from a closed side (max_recoveries): a van whose bulk is on the left, of which the
// camera first saw the right part of the rear face only, so the detour turns left; 1 m on, the
// whole face and a hedge beside the van (1.6-3 m left) close the left side up to max_offset_m.
// Kinematic robot: forward as drive_towards, reversing at 0.15 m/s with the same turn law.
struct Recovery {
  LaneDecision last;
  double min_clearance_m = 1e9;
  double min_s_m = 1e9;       // how far back it reversed
  double s_at_closing_m = -1;  // where the side closed
  double l_at_closing_m = 0.0;
  bool reversed = false;
  double lane_after_m = 0.0;  // first lane driven after the reversing
  double l_after_m = 1e9;     // the robot's offset when the reversing ended
};

Recovery recover(const LaneDetourParams& p, bool right_closes_too, bool right_closes_after) {
  const Box van{3.0, 7.8, -0.35, 1.6};
  Pose2D pose{};
  LaneDetour detour(p, pose);
  std::vector<cv::Point2d> part;  // the right part of the rear face
  for (double y = -0.35; y <= 0.3 + 1e-9; y += 0.15) part.emplace_back(3.0, y);
  detour.add_points(part);
  Recovery r;
  bool more_seen = false, wall_seen = false;
  for (int cycle = 0; cycle < 3000; ++cycle) {
    if (!more_seen && pose.x_m >= 1.0) {
      more_seen = true;
      std::vector<cv::Point2d> more;
      for (double y = 0.3; y <= 1.6 + 1e-9; y += 0.15) more.emplace_back(3.0, y);
      for (double x = 3.0; x <= 8.0 + 1e-9; x += 0.25)
        for (double y = 1.6; y <= 3.0 + 1e-9; y += 0.2) more.emplace_back(x, y);  // the hedge
      if (right_closes_too)
        for (double x = 1.5; x <= 8.0 + 1e-9; x += 0.25)
          for (double y = -0.95; y >= -3.0 - 1e-9; y -= 0.2) more.emplace_back(x, y);
      detour.add_points(more);
    }
    r.last = detour.decide(pose);
    if (r.last.kind == LaneDecision::Kind::reverse) {
      if (!r.reversed) {
        r.s_at_closing_m = r.last.s_m;
        r.l_at_closing_m = r.last.l_m;
      }
      r.reversed = true;
      const double w = std::clamp(1.5 * r.last.heading_rad, -0.6, 0.6);
      pose.heading_rad += w * 0.1;
      pose.x_m -= 0.15 * 0.1 * std::cos(pose.heading_rad);
      pose.y_m -= 0.15 * 0.1 * std::sin(pose.heading_rad);
    } else if (r.last.kind == LaneDecision::Kind::drive) {
      if (r.reversed && r.l_after_m > 1e8) r.l_after_m = r.last.l_m;
      if (r.reversed && r.lane_after_m == 0.0 && r.last.lane_m != 0.0) r.lane_after_m = r.last.lane_m;
      if (right_closes_after && r.reversed && !wall_seen && r.last.l_m < -0.5) {
        wall_seen = true;  // on the right, a second wall closes that side as well
        std::vector<cv::Point2d> wall;
        for (double x = 2.5; x <= 8.0 + 1e-9; x += 0.25)
          for (double y = -1.0; y >= -3.0 - 1e-9; y -= 0.2) wall.emplace_back(x, y);
        detour.add_points(wall);
        continue;
      }
      drive_towards(pose, r.last.heading_rad, r.last.hold_forward);
    } else {
      break;
    }
    r.min_clearance_m = std::min(r.min_clearance_m, van.distance(pose.x_m, pose.y_m));
    r.min_s_m = std::min(r.min_s_m, r.last.s_m);
  }
  return r;
}

TEST(LaneDetour, AClosedSideNearTheObstacleReversesThenPassesOnTheOtherSide) {
  const Recovery r = recover(LaneDetourParams{}, false, false);
  ASSERT_TRUE(r.reversed);
  EXPECT_EQ(r.last.kind, LaneDecision::Kind::done) << r.last.reason;
  EXPECT_GT(r.s_at_closing_m, 0.9);
  // Reversed until the face (s = 3) was recover_clear_m (3 m) ahead, not much farther.
  EXPECT_LE(r.min_s_m, 0.0 + 1e-6);
  EXPECT_GT(r.min_s_m, -0.3);
  // Back along the way it came: it had turned out from the line, so it ends nearer the line.
  EXPECT_LT(r.l_after_m, r.l_at_closing_m - 0.1) << r.l_at_closing_m << " -> " << r.l_after_m;
  EXPECT_LT(r.lane_after_m, 0.0);  // then the right side
  EXPECT_GT(r.last.s_m, 7.8);      // past the van
  EXPECT_GT(r.min_clearance_m, 0.25) << "the body touched the van";
  // Without the recovery: blocked where the side closed, with the session 13 reason.
  LaneDetourParams off;
  off.max_recoveries = 0;
  const Recovery stopped = recover(off, false, false);
  EXPECT_FALSE(stopped.reversed);
  EXPECT_EQ(stopped.last.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(stopped.last.reason.find("the left side closes"), std::string::npos) << stopped.last.reason;
  EXPECT_NE(stopped.last.reason.find("recovery by reversing tried 0 time(s)"), std::string::npos) << stopped.last.reason;
}

TEST(LaneDetour, BothSidesClosedOrTheRecoveryUsedUpStopsWithTheReason) {
  // Both sides close at once: no reversing, blocked with the reason.
  const Recovery both = recover(LaneDetourParams{}, true, false);
  EXPECT_FALSE(both.reversed);
  EXPECT_EQ(both.last.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(both.last.reason.find("the other side closes too"), std::string::npos) << both.last.reason;
  // The other side closes after the recovery: no third try, blocked with the reason.
  const Recovery again = recover(LaneDetourParams{}, false, true);
  EXPECT_TRUE(again.reversed);
  EXPECT_EQ(again.last.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(again.last.reason.find("both sides closed"), std::string::npos) << again.last.reason;
  EXPECT_GT(again.min_clearance_m, 0.25);
  // Reversing bounded: the obstacle never far enough ahead within max_reverse_m.
  LaneDetourParams short_reverse;
  short_reverse.max_reverse_m = 0.5;
  const Recovery bounded = recover(short_reverse, false, false);
  EXPECT_TRUE(bounded.reversed);
  EXPECT_EQ(bounded.last.kind, LaneDecision::Kind::blocked);
  EXPECT_NE(bounded.last.reason.find("reversed"), std::string::npos) << bounded.last.reason;
}

// The drift margin widens a lane, it does not close a side (van_path, session 15: a point 1.5 m
// right of the line, its margin grown to 0.4 m beside the van, closed the right side past the
// van's front). An obstacle from 1 m right to 3 m left of the line (s 2-8 m), a row of points
// 1.6 m right.
TEST(LaneDetour, TheDriftMarginDoesNotCloseASide) {
  LaneDetour detour(LaneDetourParams{}, Pose2D{});
  std::vector<cv::Point2d> pts;
  for (double s = 2.0; s <= 8.0 + 1e-9; s += 0.25) {
    for (double l = -1.0; l <= 3.0 + 1e-9; l += 0.2) pts.emplace_back(s, l);
    pts.emplace_back(s, -1.6);
  }
  detour.add_points(pts);
  const LaneDecision start = detour.decide(Pose2D{});
  ASSERT_EQ(start.kind, LaneDecision::Kind::drive) << start.reason;
  ASSERT_LT(start.lane_m, -2.15);  // right, beyond the row
  // 9 m on, every point seen at s = 0: margins of 0.4 m would need a lane beyond -2.6 m.
  const LaneDecision beside = detour.decide(Pose2D{9.0, -2.3, 0.0});
  EXPECT_EQ(beside.kind, LaneDecision::Kind::drive) << beside.reason;
  EXPECT_LE(beside.lane_m, -2.2 + 1e-9);
  EXPECT_GE(beside.lane_m, -2.5 - 1e-9);
}

TEST(LaneDetour, BadParamsAreOutOfRange) {
  LaneDetourParams p;
  p.clearance_m = -0.1;
  const Status st = p.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::out_of_range);
  LaneDetourParams drift;
  drift.drift_rad_per_m = 1.5;  // the port drift_rad_per_m: rad per metre, at most 1
  EXPECT_TRUE(visnav::test::fails_with(drift.validate(), ErrorCode::out_of_range, visnav::test::key_only("drift_rad_per_m")));
  LaneDetourParams recoveries;
  recoveries.max_recoveries = -1;
  EXPECT_TRUE(visnav::test::fails_with(recoveries.validate(), ErrorCode::out_of_range, visnav::test::key_only("max_recoveries")));
  LaneDetourParams clear;
  clear.recover_clear_m = 0.0;
  EXPECT_TRUE(visnav::test::fails_with(clear.validate(), ErrorCode::out_of_range, visnav::test::key_only("recover_clear_m")));
  LaneDetourParams guard;
  guard.guard_reach_m = -0.1;
  EXPECT_TRUE(visnav::test::fails_with(guard.validate(), ErrorCode::out_of_range, visnav::test::key_only("guard_reach_m")));
  guard = LaneDetourParams{};
  guard.guard_max_turn_rad = 4.0;
  EXPECT_TRUE(visnav::test::fails_with(guard.validate(), ErrorCode::out_of_range, visnav::test::key_only("guard_max_turn_rad")));
}

// ----------------------------------------------------------------------- contact repairs

ClassifiedFeature feature(FeatureClass label, double u, double v, cv::Point2d ground = {}, double d_m = -1.0) {
  ClassifiedFeature f;
  f.label = label;
  f.pixel = {u, v};
  f.ground_m = ground;
  f.discrepancy_m = d_m;
  return f;
}

TEST(ContactRanges, CutToTheTriangulatedFootOfTheBordersFeatures) {
  // Lens at the origin, 0.43 m up; a border at 2 m whose trace ended 0.2 m up projects to
  // 2·0.43/0.23 m. Its features 0.3 m up (s = 0.43/0.13) moved 2 cm: D = (s − 1)·0.02.
  const double z0 = 0.43, travel = 0.02, d = 2.0;
  ContactPoint c;
  c.pixel = {100, 150};
  c.ground_m = {d * z0 / (z0 - 0.2), 0.0};
  std::vector<ContactPoint> contacts{c};
  const double s = z0 / (z0 - 0.3);
  std::vector<ClassifiedFeature> f{feature(FeatureClass::obstacle, 102, 130, {d * s, 0.0}, (s - 1.0) * travel),
                                   feature(FeatureClass::obstacle, 98, 120, {d * s, 0.0}, (s - 1.0) * travel),
                                   // a mis-track with a huge D: the median ignores it
                                   feature(FeatureClass::obstacle, 101, 125, {d * s, 0.0}, 50 * travel),
                                   // a feature of another border, and one below the contact: not used
                                   feature(FeatureClass::obstacle, 140, 120, {1.0, 0.0}, 1.0),
                                   feature(FeatureClass::obstacle, 100, 170, {1.0, 0.0}, 1.0)};
  ProfileParams on;
  on.foot_radius_px = 10.0;  // ReplayAvoiding's default; the core's is the thesis (off)
  correct_contact_ranges(contacts, f, LensPose{}, travel, Pose2D{}, on);
  EXPECT_NEAR(contacts[0].ground_m.x, d, 1e-9);
  EXPECT_NEAR(contacts[0].range_m, d, 1e-9);
  // Never pushed farther, and off when foot_radius_px = 0.
  std::vector<ContactPoint> near{c};
  near[0].ground_m = {1.5, 0.0};
  correct_contact_ranges(near, f, LensPose{}, travel, Pose2D{}, on);
  EXPECT_NEAR(near[0].ground_m.x, 1.5, 1e-12);
  ProfileParams off;
  off.foot_radius_px = 0.0;
  std::vector<ContactPoint> kept{c};
  correct_contact_ranges(kept, f, LensPose{}, travel, Pose2D{}, off);
  EXPECT_NEAR(kept[0].ground_m.x, c.ground_m.x, 1e-12);
}

TEST(ObstacleSpans, FilledBetweenTheBordersOfOneFaceNotAcrossAGap) {
  const IptCamera cam = [] {
    IptCamera c;
    c.width_px = 320;
    c.height_px = 240;
    c.fx_px = c.fy_px = 250.0;
    c.cx_px = 159.5;
    c.cy_px = 119.5;
    c.height_m = 0.43;
    c.pitch_rad = -9.0 * CV_PI / 180.0;
    return c;
  }();
  ASSERT_TRUE(cam.validate().ok());
  ContactPoint a, b;
  a.pixel = {80, 200};
  a.ground_m = {2.0, 0.95};
  b.pixel = {240, 200};
  b.ground_m = {2.0, -0.95};
  const std::vector<ContactPoint> contacts{a, b};
  ProfileParams p;
  p.span_max_m = 2.2;  // the nodes' default; the core's is the thesis (off)
  // The face between them: obstacle features above the foot line (and ground ones below it).
  std::vector<ClassifiedFeature> face{feature(FeatureClass::obstacle, 120, 170), feature(FeatureClass::obstacle, 160, 175),
                                      feature(FeatureClass::ground, 150, 180), feature(FeatureClass::ground, 160, 220)};
  const auto filled = fill_obstacle_spans(contacts, face, cam, p);
  ASSERT_EQ(filled.size(), 11u);  // 1.9 m in 12 steps of ≤ 0.15 m, ends excluded
  for (const auto& q : filled) {
    EXPECT_NEAR(q.x, 2.0, 1e-12);
    EXPECT_LT(std::fabs(q.y), 0.95);
  }
  // Ground seen between them above the foot line: a gap, not filled.
  std::vector<ClassifiedFeature> gap{feature(FeatureClass::ground, 120, 170), feature(FeatureClass::ground, 140, 175),
                                     feature(FeatureClass::ground, 160, 160), feature(FeatureClass::ground, 200, 185),
                                     feature(FeatureClass::ground, 210, 180), feature(FeatureClass::obstacle, 150, 190)};
  EXPECT_TRUE(fill_obstacle_spans(contacts, gap, cam, p).empty());
  // Borders farther apart than span_max_m: not one obstacle.
  std::vector<ContactPoint> wide{a, b};
  wide[1].ground_m = {2.0, -1.5};
  EXPECT_TRUE(fill_obstacle_spans(wide, face, cam, p).empty());
  EXPECT_TRUE(fill_obstacle_spans(contacts, face, cam, ProfileParams{}).empty());
}

}  // namespace
}  // namespace visnav::ipt
