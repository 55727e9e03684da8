// calibrate-ipt's core (issue 16): height and pitch from tracks on flat ground.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/calibration.hpp"

namespace visnav::ipt {
namespace {

constexpr double kDeg = CV_PI / 180.0;

std::vector<CalibrationPair> ground_pairs(const IptCamera& truth, double pixel_noise, int seed, double baseline_m = 0.02,
                                          int count = 6) {
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::uniform_real_distribution<double> fwd(0.7, 2.5), side(-0.8, 0.8), turn(-0.02, 0.02);
  std::normal_distribution<double> noise(0.0, pixel_noise);
  std::vector<CalibrationPair> pairs;
  for (int k = 0; k < count; ++k) {
    CalibrationPair p;
    p.pose_a = {0.3 * k, 0.1 * k, 0.05 * k};
    p.pose_b = {p.pose_a.x_m + baseline_m * std::cos(p.pose_a.heading_rad),
                p.pose_a.y_m + baseline_m * std::sin(p.pose_a.heading_rad),
                p.pose_a.heading_rad + turn(rng)};
    const LensPose la = lens_pose(truth, p.pose_a), lb = lens_pose(truth, p.pose_b);
    for (int i = 0; i < 40; ++i) {
      const double f = fwd(rng), s = side(rng), c = std::cos(la.azimuth_rad), sn = std::sin(la.azimuth_rad);
      const cv::Vec3d g(la.x_m + f * c - s * sn, la.y_m + f * sn + s * c, 0.0);
      const auto a = project_point(truth, la, g), b = project_point(truth, lb, g);
      if (!a || !b) continue;
      p.pixels_a.emplace_back(static_cast<float>(a->x + noise(rng)), static_cast<float>(a->y + noise(rng)));
      p.pixels_b.emplace_back(static_cast<float>(b->x + noise(rng)), static_cast<float>(b->y + noise(rng)));
    }
    pairs.push_back(std::move(p));
  }
  return pairs;
}

TEST(CalibrateIpt, RecoversHeightAndPitchFromAWrongStart) {
  IptCamera truth = testing::thesis_rig();
  truth.forward_m = 0.2;
  const auto pairs = ground_pairs(truth, 0.0, 1);
  IptCamera guess = truth;
  guess.height_m = 0.55;
  guess.pitch_rad = -4.0 * kDeg;
  auto r = calibrate_height_pitch(guess, pairs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->height_m, 0.43, 1e-4);
  EXPECT_NEAR(r->pitch_rad / kDeg, -9.0, 0.01);
  EXPECT_LT(r->rms_discrepancy_m, 1e-5);
  EXPECT_GT(r->initial_rms_discrepancy_m, 0.005);
}

TEST(CalibrateIpt, WithTrackingNoiseWithinACentimetreAndHalfADegree) {
  // 0.3 px of tracking noise: frames 10 cm apart, 12 pairs of 40 tracks
  const IptCamera truth = testing::thesis_rig();
  const auto pairs = ground_pairs(truth, 0.3, 2, 0.10, 12);
  IptCamera guess = truth;
  guess.height_m = 0.35;
  guess.pitch_rad = -14.0 * kDeg;
  auto r = calibrate_height_pitch(guess, pairs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->height_m, 0.43, 0.01);
  EXPECT_NEAR(r->pitch_rad / kDeg, -9.0, 0.5);
}

TEST(CalibrateIpt, TooFewTracksOrNoBaselineIsRefused) {
  const IptCamera truth = testing::thesis_rig();
  auto pairs = ground_pairs(truth, 0.0, 3);
  pairs.resize(1);
  pairs[0].pixels_a.resize(5);
  pairs[0].pixels_b.resize(5);
  auto r = calibrate_height_pitch(truth, pairs);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::invalid_value);
  auto still = ground_pairs(truth, 0.0, 4);
  still[0].pose_b = still[0].pose_a;
  EXPECT_EQ(calibrate_height_pitch(truth, still).error().code, ErrorCode::invalid_value);
}

}  // namespace
}  // namespace visnav::ipt
