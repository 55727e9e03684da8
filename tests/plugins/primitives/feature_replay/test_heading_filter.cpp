// HeadingHistogramFilter (issue 36, part 3): accumulating the vote histograms of consecutive
// frames, shifted by the odometric rotation, gives a correct heading where single frames have too
// few votes to pass the gate or a stray peak wins; a real jump of the offset is followed within
// jump_frames(decay) frames.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "error_expect.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/feature_replay/heading_filter.hpp"

namespace {

using visnav::ErrorCode;
using visnav::feature_replay::FilteredHeading;
using visnav::feature_replay::HeadingEstimate;
using visnav::feature_replay::HeadingFilterParams;
using visnav::feature_replay::HeadingHistogramFilter;
using visnav::feature_replay::HeadingParams;
using visnav::test::At;
using visnav::test::fails_with;

constexpr double kBinPx = 20.0;
constexpr int kBins = 41;

int bin_of(double offset_px) { return static_cast<int>(std::floor((offset_px + kBinPx * kBins / 2.0) / kBinPx)); }

// One frame's histogram: `good` votes at the true offset (within +-4 px) and `stray` votes at
// random offsets, from its own generator.
std::vector<int> frame_histogram(double true_offset_px, int good, int stray, std::mt19937& rng) {
  std::vector<int> h(kBins, 0);
  std::uniform_real_distribution<double> jitter(-4.0, 4.0), anywhere(-400.0, 400.0);
  for (int i = 0; i < good; ++i) {
    const double j = jitter(rng);
    const int b = bin_of(true_offset_px + j);
    if (b >= 0 && b < kBins) ++h[static_cast<std::size_t>(b)];
  }
  for (int i = 0; i < stray; ++i) {
    const double u = anywhere(rng);
    ++h[static_cast<std::size_t>(bin_of(u))];
  }
  return h;
}

}  // namespace

TEST(HeadingFilter, ParamsAreValidatedWithTheirKey) {
  EXPECT_TRUE(HeadingFilterParams{}.validate().ok());
  HeadingFilterParams p;
  p.decay = 1.0;  // would never forget
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, At{{}, 0, "decay"}));
  p = {};
  p.full_confidence_votes = 2.0;  // below min_votes 6
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::inconsistent, At{{}, 0, "full_confidence_votes"}));
  visnav::ConfigNode node = visnav::ConfigNode::make_map();
  node.set("max_shift_px", visnav::ConfigNode::make_scalar("-3", {"f.yaml", 4}));
  auto parsed = HeadingFilterParams::schema().parse(node);
  EXPECT_TRUE(fails_with(parsed, ErrorCode::out_of_range, At{"f.yaml", 4, "max_shift_px"}));
}

TEST(HeadingFilter, ShiftForRotationUsesTheFocalLength) {
  // 640 px, 90 deg: focal 320 px; 0.1 rad CCW moves the scene 32 px right.
  EXPECT_NEAR(visnav::feature_replay::shift_px_for_rotation(0.1, 640.0, 90.0), 32.0, 1e-9);
  EXPECT_NEAR(visnav::feature_replay::shift_px_for_rotation(-0.1, 640.0, 90.0), -32.0, 1e-9);
  EXPECT_EQ(visnav::feature_replay::shift_px_for_rotation(0.1, 0.0, 90.0), 0.0);
  EXPECT_EQ(visnav::feature_replay::jump_frames(0.7), 2);
  EXPECT_EQ(visnav::feature_replay::jump_frames(0.9), 7);
  EXPECT_EQ(visnav::feature_replay::jump_frames(0.0), 1);
}

// The robot turns while the reference stays: the true offset drifts by the odometric shift every
// frame. Each frame has 4 good votes and 3 stray ones: below the estimator's min_inliers 6, so no
// single frame is valid, and a stray bin often ties. The filter, shifting its accumulation by the
// odometric rotation, is valid from the third frame on and within one bin of the truth.
TEST(HeadingFilter, FewVotesPerFrameAccumulateToTheCorrectOffset) {
  const HeadingParams hp;  // min_inliers 6: 4 good votes never pass
  ASSERT_EQ(hp.bin_width_px, kBinPx);
  ASSERT_EQ(hp.bin_count, kBins);
  HeadingHistogramFilter filter(HeadingFilterParams{}, hp.bin_width_px, hp.bin_count);
  std::mt19937 rng(5);
  const double width_px = 640.0, fov_deg = 60.0;
  const double turn_rad = 0.01;  // per frame, CCW: offset grows by ~5.5 px per frame
  const double step_px = visnav::feature_replay::shift_px_for_rotation(turn_rad, width_px, fov_deg);
  ASSERT_NEAR(step_px, 5.54, 0.01);
  double truth = -60.0;
  int valid_frames = 0, single_frame_valid = 0;
  for (int k = 0; k < 30; ++k) {
    const auto h = frame_histogram(truth, 4, 3, rng);
    int peak = 0;
    for (int i = 1; i < kBins; ++i)
      if (h[static_cast<std::size_t>(i)] > h[static_cast<std::size_t>(peak)]) peak = i;
    single_frame_valid += h[static_cast<std::size_t>(peak)] >= hp.min_inliers ? 1 : 0;
    auto f = filter.update(h, k == 0 ? 0.0 : step_px);
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_EQ(f->restarted, k == 0);
    if (k >= 2) {
      EXPECT_TRUE(f->valid) << "frame " << k << " votes " << f->votes << " confidence " << f->confidence;
      EXPECT_NEAR(f->offset_px, truth, kBinPx) << "frame " << k;
    }
    valid_frames += f->valid ? 1 : 0;
    truth += step_px;
  }
  EXPECT_EQ(single_frame_valid, 0);  // no single frame would pass the estimator's gate
  EXPECT_GE(valid_frames, 28);
}

// Without the odometric shift the same sequence smears: the accumulation must be shifted.
TEST(HeadingFilter, UnshiftedAccumulationLagsBehindATurn) {
  HeadingHistogramFilter shifted(HeadingFilterParams{}, kBinPx, kBins), unshifted(HeadingFilterParams{}, kBinPx, kBins);
  std::mt19937 rng(9);
  const double step_px = 12.0;
  double truth = -100.0;
  double err_shifted = 0.0, err_unshifted = 0.0;
  for (int k = 0; k < 20; ++k) {
    const auto h = frame_histogram(truth, 5, 0, rng);
    auto a = shifted.update(h, k == 0 ? 0.0 : step_px);
    auto b = unshifted.update(h, 0.0);
    ASSERT_TRUE(a.ok() && b.ok());
    if (k >= 5) {
      err_shifted += std::abs(a->offset_px - truth);
      err_unshifted += std::abs(b->offset_px - truth);
    }
    truth += step_px;
  }
  EXPECT_LT(err_shifted / 15.0, 8.0);
  EXPECT_GT(err_unshifted / 15.0, 10.0);
}

// The offset jumps by 160 px (the robot was pushed, a new reference view): the estimate is at the
// new offset within jump_frames(decay) frames and stays there.
TEST(HeadingFilter, FollowsARealJumpWithinJumpFrames) {
  HeadingFilterParams p;  // decay 0.7: jump_frames 2
  HeadingHistogramFilter filter(p, kBinPx, kBins);
  std::mt19937 rng(3);
  for (int k = 0; k < 15; ++k) ASSERT_TRUE(filter.update(frame_histogram(-80.0, 8, 2, rng), 0.0).ok());
  const int n = visnav::feature_replay::jump_frames(p.decay);
  ASSERT_EQ(n, 2);
  for (int k = 1; k <= 10; ++k) {
    auto f = filter.update(frame_histogram(80.0, 8, 2, rng), 0.0);
    ASSERT_TRUE(f.ok());
    if (k < n) {
      EXPECT_NEAR(f->offset_px, -80.0, kBinPx) << "frame " << k << " after the jump";
    } else {
      EXPECT_NEAR(f->offset_px, 80.0, kBinPx) << "frame " << k << " after the jump";
    }
    // Valid again once the old peak has decayed below half the new one (ambiguity < 0.5).
    if (k >= n + 2) {
      EXPECT_TRUE(f->valid) << "frame " << k;
    }
  }
}

// A shift beyond max_shift_px restarts; a histogram of the wrong size or a NaN shift is an error
// that leaves the accumulation as it was.
TEST(HeadingFilter, LargeShiftRestartsAndBadInputIsRefused) {
  HeadingFilterParams p;
  p.max_shift_px = 50.0;
  HeadingHistogramFilter filter(p, kBinPx, kBins);
  std::mt19937 rng(1);
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(filter.update(frame_histogram(0.0, 10, 0, rng), 0.0).ok());
  const std::vector<double> before(filter.accumulated().begin(), filter.accumulated().end());
  const std::vector<int> short_histogram(7, 1);
  EXPECT_TRUE(fails_with(filter.update(short_histogram, 0.0), ErrorCode::inconsistent));
  EXPECT_TRUE(fails_with(filter.update(frame_histogram(0.0, 1, 0, rng), std::nan("")), ErrorCode::invalid_value));
  EXPECT_EQ(std::vector<double>(filter.accumulated().begin(), filter.accumulated().end()), before);
  auto f = filter.update(frame_histogram(100.0, 10, 0, rng), 80.0);  // > 50 px: restart
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f->restarted);
  EXPECT_NEAR(f->votes, 10.0, 1e-9);  // only this frame's votes
  EXPECT_NEAR(f->offset_px, 100.0, kBinPx);
  // A fractional shift keeps the mass (inside the range) and moves its centre.
  HeadingHistogramFilter g(HeadingFilterParams{}, kBinPx, kBins);
  std::vector<int> one(kBins, 0);
  one[kBins / 2] = 10;
  ASSERT_TRUE(g.update(one, 0.0).ok());
  const std::vector<int> none(kBins, 0);
  auto moved = g.update(none, 5.0);  // a quarter bin to the right
  ASSERT_TRUE(moved.ok());
  EXPECT_NEAR(moved->votes, 10.0 * 0.7, 1e-9);
  EXPECT_NEAR(moved->offset_px, 5.0, 1e-9);
}
