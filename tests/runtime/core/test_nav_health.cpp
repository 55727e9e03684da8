// Lost detection shared by the primitives (visnav/nav_health.hpp): blind -> slowing -> lost,
// frozen camera only while moving, saturation, heading deviation, state carried between edges.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>

#include "error_expect.hpp"
#include "visnav/nav_health.hpp"

using visnav::LostPolicy;
using visnav::NavHealthMonitor;
using visnav::NavHealthState;
using visnav::TaughtHeading;

namespace {

/// A fresh noisy frame each call (a live camera).
cv::Mat live_frame(int seed) {
  cv::Mat m(24, 32, CV_8UC3);
  cv::RNG rng(static_cast<std::uint64_t>(seed) + 1);
  rng.fill(m, cv::RNG::UNIFORM, 0, 255);
  return m;
}

}  // namespace

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(NavHealth, PolicyValidationNamesTheKey) {
  LostPolicy p;
  EXPECT_TRUE(p.validate().ok());
  p.max_blind_m = 0.5;
  p.slow_after_m = 1.0;
  auto st = p.validate();
  EXPECT_TRUE(fails_with(st, ErrorCode::inconsistent, key_only("max_blind_m")));
  p = LostPolicy{};
  p.slow_speed_factor = 0.0;
  EXPECT_FALSE(p.validate().ok());
  p = LostPolicy{};
  p.window_frames = 0;
  EXPECT_FALSE(p.validate().ok());
}

TEST(NavHealth, BlindThenSlowingThenLostWithDistanceInTheReason) {
  LostPolicy p;
  p.slow_after_m = 1.0;
  p.max_blind_m = 3.0;
  NavHealthMonitor m(p);
  m.begin(10.0, 0.0, std::nullopt, std::nullopt);
  double d = 10.0;
  int frame = 0;
  for (int i = 0; i < 10; ++i, d += 0.05) m.update(d, 0.0, d - 10.0, live_frame(frame++), 0.8, false);
  EXPECT_EQ(m.verdict().state, NavHealthState::seeing);
  const double seen_at = m.confident_at_m();
  EXPECT_NEAR(seen_at, d - 0.05, 1e-9);
  // the view is lost: zero confidence from here
  NavHealthState state = NavHealthState::seeing;
  double slowed_at = -1, lost_at = -1;
  while (d < 20.0) {
    const auto& v = m.update(d, 0.0, d - 10.0, live_frame(frame++), 0.0, false);
    if (v.state == NavHealthState::slowing && slowed_at < 0) {
      slowed_at = d;
      EXPECT_DOUBLE_EQ(v.speed_factor, p.slow_speed_factor);
    }
    state = v.state;
    if (v.must_stop()) {
      lost_at = d;
      EXPECT_NE(v.reason.find("lost: no confident frame for 3."), std::string::npos) << v.reason;
      EXPECT_EQ(v.speed_factor, 0.0);
      break;
    }
    d += 0.05;
  }
  EXPECT_EQ(state, NavHealthState::lost);
  // The window mean keeps the route "seen" for a few frames after the last good one.
  EXPECT_NEAR(slowed_at - seen_at, p.slow_after_m + 0.15, 0.16);
  EXPECT_NEAR(lost_at - seen_at, p.max_blind_m + 0.15, 0.16);
}

TEST(NavHealth, ASingleLuckyFrameDoesNotResetBlindness) {
  NavHealthMonitor m(LostPolicy{});
  m.begin(0.0, 0.0, std::nullopt, std::nullopt);
  double d = 0.0;
  for (int i = 0; i < 20; ++i, d += 0.05) m.update(d, 0.0, d, live_frame(i), 0.0, false);
  const double blind = m.verdict().blind_m;
  m.update(d, 0.0, d, live_frame(100), 0.9, false);  // one spurious match among garbage
  EXPECT_GE(m.verdict().blind_m, blind);
}

TEST(NavHealth, FrozenCameraWhileMovingStopsButAStandingRobotDoesNot) {
  LostPolicy p;
  p.max_frozen_m = 0.5;
  NavHealthMonitor m(p);
  m.begin(0.0, 0.0, std::nullopt, std::nullopt);
  const cv::Mat still = live_frame(7);
  // standing still: the same image for 100 frames is fine
  for (int i = 0; i < 100; ++i) m.update(0.0, 0.0, 0.0, still, 0.9, false);
  EXPECT_FALSE(m.verdict().must_stop());
  // moving with the same image: frozen after 0.5 m
  double d = 0.0;
  int frames = 0;
  while (!m.verdict().must_stop() && d < 5.0) {
    d += 0.03;
    ++frames;
    m.update(d, 0.0, d, still, 0.9, false);
  }
  EXPECT_EQ(m.verdict().state, NavHealthState::frozen);
  EXPECT_NEAR(d, 0.5, 0.04);
  EXPECT_NE(m.verdict().reason.find("camera frozen"), std::string::npos);
  // A copy of the same pixels in another buffer is still the same image; a padded ROI hashes its pixels only.
  cv::Mat big(30, 40, CV_8UC3, cv::Scalar(1, 2, 3));
  still.copyTo(big(cv::Rect(0, 0, 32, 24)));
  EXPECT_EQ(NavHealthMonitor::image_hash(big(cv::Rect(0, 0, 32, 24))), NavHealthMonitor::image_hash(still.clone()));
  EXPECT_NE(NavHealthMonitor::image_hash(live_frame(8)), NavHealthMonitor::image_hash(still));
}

TEST(NavHealth, SaturatedCorrectionForTooLongIsLost) {
  LostPolicy p;
  p.max_saturated_m = 2.0;
  NavHealthMonitor m(p);
  m.begin(0.0, 0.0, std::nullopt, std::nullopt);
  double d = 0.0;
  int i = 0;
  for (; d < 1.9; d += 0.05) EXPECT_FALSE(m.update(d, 0.0, d, live_frame(i++), 0.9, true).must_stop());
  m.update(d, 0.0, d, live_frame(i++), 0.9, false);  // one unsaturated frame restarts the count
  for (double s = d; d < s + 1.9; d += 0.05) EXPECT_FALSE(m.update(d, 0.0, d, live_frame(i++), 0.9, true).must_stop());
  for (double s = d; d < s + 2.5 && !m.verdict().must_stop(); d += 0.05) m.update(d, 0.0, d, live_frame(i++), 0.9, true);
  EXPECT_EQ(m.verdict().state, NavHealthState::lost);
  EXPECT_NE(m.verdict().reason.find("saturated"), std::string::npos);
}

TEST(NavHealth, OdometryHeadingFarOffTheTaughtProfileIsLost) {
  LostPolicy p;
  p.max_heading_deviation_rad = 75.0 * std::numbers::pi / 180.0;
  p.max_blind_m = 100.0;  // this test jumps along the edge; blindness is another test's
  NavHealthMonitor m(p);
  // an edge that turns 90 deg left over 10 m; the robot starts at odometric heading 1.0 rad
  m.begin(0.0, 1.0, std::nullopt, std::nullopt, TaughtHeading{10.0, std::numbers::pi / 2});
  EXPECT_FALSE(m.update(5.0, 1.0 + std::numbers::pi / 4 + 0.3, 5.0, live_frame(1), 0.9, false).must_stop());
  // turned around by an outside command: 170 deg off
  const auto& v = m.update(5.1, 1.0 + std::numbers::pi / 4 + 170.0 * std::numbers::pi / 180.0, 5.1, live_frame(2), 0.9, false);
  EXPECT_EQ(v.state, NavHealthState::lost);
  EXPECT_NE(v.reason.find("odometry heading"), std::string::npos) << v.reason;
  // 0 disables the check
  p.max_heading_deviation_rad = 0.0;
  NavHealthMonitor off(p);
  off.begin(0.0, 0.0, std::nullopt, std::nullopt, TaughtHeading{10.0, 0.0});
  EXPECT_FALSE(off.update(1.0, 3.0, 1.0, live_frame(3), 0.9, false).must_stop());
}

TEST(NavHealth, BlindnessCarriesAcrossEdgesSoShortEdgesCannotHideIt) {
  LostPolicy p;
  p.max_blind_m = 3.0;
  NavHealthMonitor m(p);
  m.begin(0.0, 0.0, std::nullopt, std::nullopt);
  int i = 0;
  for (double d = 0.0; d < 2.0; d += 0.05) m.update(d, 0.0, d, live_frame(i++), 0.0, false);
  const double confident_at = m.confident_at_m();
  EXPECT_EQ(confident_at, 0.0);
  // next edge of 2 m: starts with the carried distance and stops within it
  NavHealthMonitor next(p);
  next.begin(2.0, 0.0, confident_at, m.changed_at_m());
  bool stopped = false;
  for (double d = 2.0; d < 4.0 && !stopped; d += 0.05) stopped = next.update(d, 0.0, d - 2.0, live_frame(i++), 0.0, false).must_stop();
  EXPECT_TRUE(stopped);
  // a carried value from the future (odometry reset) or NaN restarts the count instead
  NavHealthMonitor fresh(p);
  fresh.begin(1.0, 0.0, 50.0, std::nan(""));
  EXPECT_EQ(fresh.confident_at_m(), 1.0);
  EXPECT_EQ(fresh.changed_at_m(), 1.0);
}

TEST(NavHealth, WhereTheMapExpectsNothingTheBlindCountPausesButAFrozenCameraStillStops) {
  LostPolicy p;
  p.max_blind_m = 3.0;
  NavHealthMonitor m(p);
  m.begin(0.0, 0.0, std::nullopt, std::nullopt);
  int i = 0;
  double d = 0.0;
  for (; d < 1.0; d += 0.05) m.update(d, 0.0, d, live_frame(i++), 0.0, false, /*informative=*/true);
  const double blind = m.verdict().blind_m;
  EXPECT_GT(blind, 0.8);
  // 10 m of featureless map: no match is expected, the count pauses
  for (; d < 11.0; d += 0.05) EXPECT_FALSE(m.update(d, 0.0, d, live_frame(i++), 0.0, false, false).must_stop());
  EXPECT_NEAR(m.verdict().blind_m, blind, 0.06);
  // where the map expects landmarks again, blindness grows from where it was
  bool stopped = false;
  for (; d < 20.0 && !stopped; d += 0.05) stopped = m.update(d, 0.0, d, live_frame(i++), 0.0, false, true).must_stop();
  EXPECT_TRUE(stopped);
  EXPECT_NEAR(d, 11.0 + (3.0 - blind), 0.3);
  // a frozen camera is a frozen camera wherever the robot is
  NavHealthMonitor f(p);
  f.begin(0.0, 0.0, std::nullopt, std::nullopt);
  const cv::Mat still = live_frame(3);
  bool frozen = false;
  for (d = 0.0; d < 3.0 && !frozen; d += 0.05) frozen = f.update(d, 0.0, d, still, 0.0, false, false).must_stop();
  EXPECT_EQ(f.verdict().state, NavHealthState::frozen);
}
