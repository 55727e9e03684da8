// When a stopped robot may cross a walking person's way (crossing_policy.hpp): synthetic tracks
// of a person's ground point (robot frame, x ahead, y left) and synthetic frame-difference masks.
#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "error_expect.hpp"
#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/crossing_policy.hpp"
#include "visnav/ipt_obstacles/motion_watch.hpp"

namespace visnav::ipt {
namespace {

using visnav::test::fails_with;
using visnav::test::key_only;
using Kind = CrossingDecision::Kind;

/// Feeds a person walking from (x, y0) with lateral velocity vy for `duration_s`, a point every
/// 0.1 s with 3 cm of noise each way; returns the decision at the last point.
CrossingDecision walk(CrossingPolicy& policy, double x, double y0, double vy, double t0, double duration_s) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.03);
  double t = t0;
  for (; t <= t0 + duration_s + 1e-9; t += 0.1) {
    MovingPoint p;
    const double ex = noise(rng);
    const double ey = noise(rng);
    p.ground_m = {x + ex, y0 + vy * (t - t0) + ey};
    policy.observe(t, p);
  }
  return policy.decide(t - 0.1);
}

TEST(CrossingPolicy, WalkingAwayGoesApproachingWithinTheCrossingTimeWaits) {
  CrossingParams params;  // lane ±0.6 m, crossing 3.5 s, away_clear 0.3 m
  ASSERT_TRUE(params.validate().ok());
  {
    // It has just crossed the robot's line 1.5 m ahead and walks away to the right at 1 m/s.
    CrossingPolicy policy(params);
    const auto d = walk(policy, 1.5, -0.4, -1.0, 0.0, 0.6);  // ends at y = -1.0
    EXPECT_EQ(d.kind, Kind::go) << d.reason;
    EXPECT_NEAR(d.lateral_m, -1.0, 0.1);
    EXPECT_NEAR(d.lateral_speed_mps, 1.0, 0.2);
    // Out of view for 1 s: the line is extrapolated, it is still walking away.
    const auto later = policy.decide(1.6);
    EXPECT_EQ(later.kind, Kind::go) << later.reason;
    EXPECT_NEAR(later.lateral_m, -2.0, 0.25);
    // Not seen for longer than forget_s: no track (the caller's own rule decides).
    EXPECT_EQ(policy.decide(2.8).kind, Kind::no_track);
  }
  {
    // Walking towards the lane from the left, 1.9 m from its edge at 1 m/s: arrives in 1.9 s,
    // within the 3.5 s the robot needs.
    CrossingPolicy policy(params);
    const auto d = walk(policy, 2.0, 3.0, -1.0, 0.0, 0.5);
    EXPECT_EQ(d.kind, Kind::wait) << d.reason;
    EXPECT_NEAR(d.arrival_s, 1.9, 0.3);
  }
  {
    // The same walk 6 m to the side: arrives after the crossing time, go.
    CrossingPolicy policy(params);
    const auto d = walk(policy, 2.0, 7.1, -1.0, 0.0, 0.5);
    EXPECT_EQ(d.kind, Kind::go) << d.reason;
    EXPECT_GT(d.arrival_s, params.crossing_s);
    // And with a longer crossing time it waits.
    CrossingParams slow = params;
    slow.crossing_s = 8.0;
    CrossingPolicy careful(slow);
    EXPECT_EQ(walk(careful, 2.0, 7.1, -1.0, 0.0, 0.5).kind, Kind::wait);
  }
  {
    // Crossing the lane: wait, whichever way it walks.
    CrossingPolicy policy(params);
    EXPECT_EQ(walk(policy, 1.2, 0.4, -1.0, 0.0, 0.5).kind, Kind::wait);  // ends at y = -0.1
  }
  {
    // Standing just beside the lane (0.1 m beyond its edge): wait; 0.6 m beyond: go.
    CrossingPolicy near(params);
    EXPECT_EQ(walk(near, 1.5, 0.7, 0.0, 0.0, 0.5).kind, Kind::wait);
    CrossingPolicy beside(params);
    EXPECT_EQ(walk(beside, 1.5, 1.2, 0.0, 0.0, 0.5).kind, Kind::go);
  }
  {
    // Too few points for a direction: wait; nothing at all: no track.
    CrossingPolicy policy(params);
    EXPECT_EQ(policy.decide(0.0).kind, Kind::no_track);
    EXPECT_EQ(walk(policy, 1.5, 2.0, 1.0, 0.0, 0.1).kind, Kind::wait);
  }
}

TEST(CrossingPolicy, RemembersWhereAPersonCrossedAheadUntilTheRobotPassesIt) {
  CrossingLanes lanes;
  const double h = 0.5;  // the robot drives along heading 0.5 rad in the odometry frame
  auto at = [&](double s) { return Pose2D{1.0 + s * std::cos(h), 2.0 + s * std::sin(h), h}; };
  EXPECT_FALSE(lanes.ahead_m(at(0.0), 0.0, 30.0).has_value());
  // Seen 3.1 m ahead, 1.2 m to the right, walking across.
  lanes.add(at(0.0), {3.1, -1.2}, 0.0);
  auto ahead = lanes.ahead_m(at(0.0), 0.1, 30.0);
  ASSERT_TRUE(ahead.has_value());
  EXPECT_NEAR(*ahead, 3.1, 1e-9);
  ahead = lanes.ahead_m(at(2.4), 8.0, 30.0);  // 2.4 m further on: 0.7 m to go
  ASSERT_TRUE(ahead.has_value());
  EXPECT_NEAR(*ahead, 0.7, 1e-9);
  EXPECT_FALSE(lanes.ahead_m(at(3.2), 11.0, 30.0).has_value());  // passed: dropped
  EXPECT_EQ(lanes.size(), 0u);
  lanes.add(at(0.0), {3.1, 0.0}, 0.0);
  EXPECT_FALSE(lanes.ahead_m(at(1.0), 31.0, 30.0).has_value());  // too old: dropped
}

// A person pacing across the way 0.7 m ahead of a robot stopped at its edge, seen only while
// within ±0.4 m of the robot's line (the camera's view there): it walks 2.35 m past the line to
// the right and 3.65 m to the left before it turns (returns after 4.7 s and 7.3 s).
TEST(CrossingPolicy, LearnsWhenAPacingPersonComesBackAndGoesOnlyAfterTheLongReturn) {
  CrossingParams params;
  params.crossing_s = 5.5;
  CrossingPolicy policy(params);
  auto pass = [&](double t0, double dir) {  // one pass in view, 0.1 s apart
    CrossingDecision d;
    for (double y = -0.4 * dir; y * dir <= 0.4 + 1e-9; y += 0.1 * dir, t0 += 0.1) {
      MovingPoint p;
      p.ground_m = {0.95, y};
      policy.observe(t0, p);
    }
    return policy.decide(t0 + 0.6, true);  // 0.6 s later, out of view, extrapolated
  };
  // First pass to the right: its return is not known: a cautious robot waits.
  auto d = pass(0.0, -1.0);
  EXPECT_EQ(d.kind, CrossingDecision::Kind::wait) << d.reason;
  EXPECT_LT(policy.return_after_s(-1), 0.0);
  // It comes back 4.7 s later walking left: the return after a pass to the right is 4.7 s; the
  // one after a pass to the left is not known yet.
  d = pass(4.7, 1.0);
  EXPECT_NEAR(policy.return_after_s(-1), 4.7, 0.11);
  EXPECT_EQ(d.kind, CrossingDecision::Kind::wait) << d.reason;
  // Back again 7.3 s later walking right: that return (4.7 s) is within the crossing time: wait.
  d = pass(12.0, -1.0);
  EXPECT_NEAR(policy.return_after_s(1), 7.3, 0.11);
  EXPECT_EQ(d.kind, CrossingDecision::Kind::wait) << d.reason;
  // The next pass to the left is followed by a 7.3 s return: go.
  d = pass(16.7, 1.0);
  EXPECT_EQ(d.kind, CrossingDecision::Kind::go) << d.reason;
  // Not cautious (a stop away from the way): an unknown return does not hold it.
  CrossingPolicy plain(params);
  for (double t = 0.0, y = -0.4; y >= -1.2; y -= 0.1, t += 0.1) {
    MovingPoint p;
    p.ground_m = {1.5, y};
    plain.observe(t, p);
  }
  EXPECT_EQ(plain.decide(0.8, false).kind, CrossingDecision::Kind::go);
  EXPECT_EQ(plain.decide(0.8, true).kind, CrossingDecision::Kind::wait);
}

// The located feet jitter about the line while a person crosses it (their spread): points that
// flip back across the line before one was seen pass_fit_m beyond it are one pass, not a pass
// and a return 0.1 s later. Counted as a return, such flips taught the policy that a pacing
// person comes back at once, and a robot at the person's way waited until it gave up.
TEST(CrossingPolicy, JitterAboutTheLineIsNeitherAPassNorAReturn) {
  CrossingParams params;
  params.speed_mps = 0.6;
  CrossingPolicy policy(params);
  auto observe = [&](double t, double y) {
    MovingPoint p;
    p.ground_m = {0.95, y};
    policy.observe(t, p);
  };
  // Walking left across the line at 1 m/s, the located point flipping back once at the line.
  const double ys[] = {-0.4, -0.3, -0.2, -0.1, 0.05, -0.05, 0.1, 0.2, 0.3, 0.4};
  double t = 0.0;
  for (double y : ys) observe(t += 0.1, y);
  EXPECT_LT(policy.return_after_s(1), 0.0) << "a flip 0.1 s after the pass was taken for the return";
  EXPECT_LT(policy.return_after_s(-1), 0.0);
  // It was seen 0.4 m beyond the line on the left; it comes back walking right, across the line
  // at t = 6.4 s, 5.9 s after its pass (t = 0.5 s): the return after a pass to the left.
  t = 5.9;
  for (double y : {0.4, 0.3, 0.2, 0.1, -0.05, -0.1, -0.2}) observe(t += 0.1, y);
  EXPECT_NEAR(policy.return_after_s(1), 5.9, 0.01);
  EXPECT_LT(policy.return_after_s(-1), 0.0);
}

// The time the robot needs to be past a person's way, from the geometry (crossing_speed_mps).
TEST(CrossingPolicy, ClearTimeIsTheDistancePastThePersonAtTheCrossingSpeedFromRest) {
  CrossingParams p;  // body 0.25 m, person 0.25 m, margin 0.1 m, 0.5 m/s^2
  // 0.7 m to the way's centre + the person's radius + the robot's + the margin.
  EXPECT_NEAR(clear_distance_m(p, 0.7), 1.3, 1e-9);
  EXPECT_NEAR(clear_distance_m(p, -0.2), 0.6, 1e-9);  // already on the way: its far side only
  p.speed_mps = 0.3;  // the replay's speed: 1.3 / 0.3 + 0.3 / (2 * 0.5)
  EXPECT_NEAR(clear_time_s(p, 0.7), 1.3 / 0.3 + 0.3, 1e-9);
  p.speed_mps = 0.6;  // twice as fast, but 0.6 s lost accelerating
  EXPECT_NEAR(clear_time_s(p, 0.7), 1.3 / 0.6 + 0.6, 1e-9);
  p.speed_mps = 2.0;  // never reaches 2 m/s within 1.3 m: sqrt(2 d / a)
  EXPECT_NEAR(clear_time_s(p, 0.7), std::sqrt(2.0 * 1.3 / 0.5), 1e-9);
  p.speed_mps = 0.0;  // deprecated: the hand-set crossing_s
  p.crossing_s = 5.5;
  EXPECT_DOUBLE_EQ(clear_time_s(p, 0.7), 5.5);
  // A lane narrower than the two bodies cannot keep a person outside it off the robot.
  p.speed_mps = 0.6;
  p.lane_half_width_m = 0.45;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::inconsistent, key_only("lane_half_width_m")));
  p = CrossingParams{};
  p.speed_mps = 2.5;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("speed_mps")));
}

// The campus's blind walker seen from the middle of its walk: a robot stopped 0.7 m before its
// way, the person pacing across it and back with 6 s between passes each way (3 m to either side
// at 1 m/s), seen only within +-0.4 m of the robot's line. At the replay's 0.3 m/s the robot
// needs 4.6 s + 0.5 s margin to be past it, and the person is back in its lane 4.4 s after it
// walks clear: wait on every pass. At 0.6 m/s (2.8 s + 0.5 s): go after the return is known.
TEST(CrossingPolicy, APersonPacingWithSixSecondReturnsWaitsAtReplaySpeedAndGoesAtTheCrossingSpeed) {
  auto pace = [](double speed_mps) {
    CrossingParams params;
    params.speed_mps = speed_mps;
    CrossingPolicy policy(params);
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.03);
    std::vector<CrossingDecision> after_pass;  // the first go (else the last wait) after each pass
    double dir = -1.0;                          // the first pass walks to the robot's right
    for (double pass_s = 1.0; pass_s < 31.0; pass_s += 6.0, dir = -dir) {
      for (double dt = -0.7; dt <= 0.7 + 1e-9; dt += 0.1) {
        // In view up to |y| = 0.4 m; the body leaving the view is seen at its edge (the changed
        // pixels of its part still in view), which slows the fitted track.
        MovingPoint p;
        const double ex = noise(rng);
        const double ey = noise(rng);
        p.ground_m = {0.95 + ex, std::clamp(dir * dt, -0.4, 0.4) + ey};  // feet below the image: the bottom row
        policy.observe(pass_s + dt, p);
      }
      CrossingDecision d;
      for (double dt = 0.8; dt <= 1.9 + 1e-9; dt += 0.1) {  // out of view, extrapolated
        d = policy.decide(pass_s + dt, true, 0.7);         // the remembered way 0.7 m ahead
        if (d.kind == Kind::go) break;
      }
      after_pass.push_back(d);
    }
    return std::make_pair(after_pass, policy.return_after_s(1));
  };
  const auto [slow, slow_return] = pace(0.3);
  EXPECT_NEAR(slow_return, 6.0, 0.15);
  for (const auto& d : slow) EXPECT_EQ(d.kind, Kind::wait) << d.reason;
  EXPECT_NEAR(slow.back().required_s, 1.3 / 0.3 + 0.3 + 0.5, 0.01);
  const auto [fast, fast_return] = pace(0.6);
  EXPECT_NEAR(fast_return, 6.0, 0.15);
  // Passes 1 and 2: the return after a pass that way is not known yet (cautious): wait.
  EXPECT_EQ(fast[0].kind, Kind::wait) << fast[0].reason;
  EXPECT_EQ(fast[1].kind, Kind::wait) << fast[1].reason;
  for (std::size_t i = 2; i < fast.size(); ++i) {
    EXPECT_EQ(fast[i].kind, Kind::go) << i << ": " << fast[i].reason;
    // Back in the lane 6 s after its pass minus the time since the pass (walked clear of the
    // lane's edge + 0.3 m by then: 0.9-1.0 s at the pass's 1 m/s), minus 0.6 s from the lane's
    // edge to the line.
    EXPECT_NEAR(fast[i].arrival_s, 6.0 - 0.95 - 0.6, 0.25) << fast[i].reason;
    EXPECT_GE(fast[i].arrival_s, fast[i].required_s);
    EXPECT_NEAR(fast[i].required_s, 1.3 / 0.6 + 0.6 + 0.5, 0.01);
  }
  // The deprecated hand-set 5.5 s compared the 6 s return itself: it let the robot go at 0.3 m/s.
  CrossingParams old;
  old.crossing_s = 5.5;
  CrossingPolicy hand_set(old);
  double dir = -1.0;
  CrossingDecision d;
  for (double pass_s = 1.0; pass_s < 14.0; pass_s += 6.0, dir = -dir) {
    for (double dt = -0.4; dt <= 0.4 + 1e-9; dt += 0.1) {
      MovingPoint p;
      p.ground_m = {0.95, dir * dt};
      hand_set.observe(pass_s + dt, p);
    }
    d = hand_set.decide(pass_s + 1.0, true);
  }
  EXPECT_EQ(d.kind, Kind::go) << d.reason;
}

TEST(CrossingPolicy, BadParamsNameTheKey) {
  CrossingParams p;
  p.crossing_s = 0.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("crossing_s")));
  p = CrossingParams{};
  p.lane_half_width_m = -1.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("lane_half_width_m")));
  p = CrossingParams{};
  p.forget_s = 0.5;  // below window_s 1.0
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::inconsistent, key_only("forget_s")));
}

TEST(CrossingPolicy, LocatesTheFeetOfTheChangedPixels) {
  const IptCamera camera = testing::thesis_rig();  // 256x192, horizon near row 64
  cv::Mat changed = cv::Mat::zeros(camera.height_px, camera.width_px, CV_8UC1);
  // A body right of the centre: columns 180-200, rows 70-150 (feet at row 150).
  changed(cv::Rect(180, 70, 21, 81)).setTo(255);
  auto p = locate_moving(changed, camera, 100);
  ASSERT_TRUE(p.ok() && p->has_value());
  const GroundHit feet = back_project(camera, lens_pose(camera, Pose2D{}), {190.5, 150.5});
  ASSERT_TRUE(feet.valid());
  const cv::Point2d expected = to_robot_frame(Pose2D{}, feet.ground_m);
  EXPECT_NEAR((*p)->ground_m.x, expected.x, 0.05);
  EXPECT_NEAR((*p)->ground_m.y, expected.y, 0.05);
  EXPECT_LT((*p)->ground_m.y, 0.0);  // right of the robot
  EXPECT_TRUE((*p)->contact_visible);
  // A few stray pixels elsewhere do not move it.
  changed(cv::Rect(10, 100, 3, 3)).setTo(255);
  auto q = locate_moving(changed, camera, 100);
  ASSERT_TRUE(q.ok() && q->has_value());
  EXPECT_NEAR((*q)->ground_m.y, expected.y, 0.05);
  // Feet below the image: the bottom row's ground point, flagged.
  changed(cv::Rect(60, 90, 20, 102)).setTo(255);
  changed(cv::Rect(180, 70, 21, 81)).setTo(0);
  auto close = locate_moving(changed, camera, 100);
  ASSERT_TRUE(close.ok() && close->has_value());
  EXPECT_FALSE((*close)->contact_visible);
  EXPECT_GT((*close)->ground_m.y, 0.0);  // left of the robot
  // Too few changed pixels: nothing; a wrong mask: an error.
  auto none = locate_moving(cv::Mat::zeros(camera.height_px, camera.width_px, CV_8UC1), camera, 100);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  EXPECT_TRUE(fails_with(locate_moving(cv::Mat(10, 10, CV_8UC1), camera, 100), ErrorCode::invalid_value));
}


// The driving trigger shared by ReplayAvoiding's near corridor and the crossing watch's band:
// shimmer at its usual level never fires, a count far above it fires on its second frame in a
// row, a single spike does not, and counts while not cruising neither fire nor move the level.
TEST(ShimmerTrigger, FiresOnTwoFramesWellAboveTheRecentLevelOnly) {
  ShimmerTrigger trigger;
  // Fewer than 5 levels known: even a large count does not fire.
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(trigger.update(5000, true, true));
  ShimmerTrigger t;
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(t.update(400 + 20 * (i % 5), true, true)) << i;
  EXPECT_FALSE(t.update(5000, true, true));  // one spike
  EXPECT_FALSE(t.update(450, true, true));
  EXPECT_FALSE(t.update(5000, true, true));
  EXPECT_TRUE(t.update(5000, true, true));   // the second frame in a row
  EXPECT_TRUE(t.update(6000, true, true));
  t.reset_hits();
  EXPECT_FALSE(t.update(5000, true, true));  // a new run of frames starts over
  // The watch's own verdict must agree.
  t.reset_hits();
  EXPECT_FALSE(t.update(5000, true, false));
  EXPECT_FALSE(t.update(5000, true, false));
  // Not cruising: no fire, and the large counts do not raise the level.
  ShimmerTrigger s;
  for (int i = 0; i < 6; ++i) EXPECT_FALSE(s.update(500, true, true));
  for (int i = 0; i < 20; ++i) EXPECT_FALSE(s.update(8000, false, true));
  EXPECT_FALSE(s.update(2000, true, true));
  EXPECT_TRUE(s.update(2000, true, true));  // still judged against the level of 500
}

}  // namespace
}  // namespace visnav::ipt
