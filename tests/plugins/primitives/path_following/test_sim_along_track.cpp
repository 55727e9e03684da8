// The path replay's along-track estimate (along_track.hpp) on views rendered along the campus
// gravel path e14 (west from x = 31 m at y = -26 m): a replay whose odometry reads 4 % short ends
// the edge where the taught views end, not 4 % late.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "visnav/path_following/along_track.hpp"
#include "visnav/path_payload.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace pf = visnav::path_following;
namespace sim = visnav::sim;
namespace pp = visnav::path_payload;

namespace {

constexpr double kStartX = 31.0;
constexpr double kPathY = -26.0;
constexpr double kLengthM = 20.0;

class AlongTrackSim : public ::testing::Test {
 protected:
  void SetUp() override {
    auto world = sim::load_world(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/campus.yaml");
    ASSERT_TRUE(world.ok()) << world.error().message;
    world_ = *world;
    renderer_.emplace(world_, sim::CameraModel{});
    // The teach run: a thumbnail every 0.5 m along the path, as TeachPathEdge stores them.
    for (double d = 0.0; d <= kLengthM + 1e-9; d += 0.5) {
      renderer_->render(pose_at(d, 0.0, 0.0), frame_);
      auto t = pp::make_thumbnail(frame_);
      ASSERT_TRUE(t.ok());
      taught_.push_back({d, *t});
    }
  }

  static visnav::Pose2D pose_at(double along_m, double lateral_m, double heading_error_rad) {
    // Heading west (pi); lateral + is to the robot's left (south).
    return visnav::Pose2D{kStartX - along_m, kPathY - lateral_m, std::numbers::pi + heading_error_rad};
  }

  std::shared_ptr<const sim::World> world_;
  std::optional<sim::Renderer> renderer_;
  std::vector<pp::Thumbnail> taught_;
  cv::Mat frame_;
};

TEST_F(AlongTrackSim, OdometryThatReadsShortIsCorrectedToTheTaughtViews) {
  pf::AlongTrackEstimator estimator(pf::AlongTrackParams{}, taught_);
  ASSERT_TRUE(estimator.active());
  // The replay: 0.5 m/s at 10 Hz, 0.15 m left of the taught line, 2 deg off, odometry 4 % short.
  double worst_late_m = 0.0;
  for (double truth_m = 0.0; truth_m <= kLengthM - 1.0; truth_m += 0.05) {
    const double odometric_m = truth_m * 0.96;
    renderer_->render(pose_at(truth_m, 0.15, 2.0 * std::numbers::pi / 180.0), frame_);
    estimator.update(frame_, odometric_m);
    if (truth_m > 8.0) worst_late_m = std::max(worst_late_m, std::abs(odometric_m + estimator.shift_m() - truth_m));
  }
  const double truth_m = kLengthM - 1.0;
  const double uncorrected_m = truth_m - truth_m * 0.96;  // 0.76 m
  EXPECT_NEAR(estimator.shift_m(), uncorrected_m, 0.15) << estimator.accepted() << " accepted, " << estimator.rejected()
                                                          << " rejected";
  EXPECT_LT(worst_late_m, 0.3);  // over the edge's second half, not only at its end
  EXPECT_GT(estimator.accepted(), 100);
}

TEST_F(AlongTrackSim, OdometryThatReadsLongIsCorrectedToo) {
  pf::AlongTrackEstimator estimator(pf::AlongTrackParams{}, taught_);
  for (double truth_m = 0.0; truth_m <= kLengthM - 1.0; truth_m += 0.05)
    renderer_->render(pose_at(truth_m, -0.1, 0.0), frame_), estimator.update(frame_, truth_m * 1.03);
  const double truth_m = kLengthM - 1.0;
  EXPECT_NEAR(estimator.shift_m(), truth_m - truth_m * 1.03, 0.15);
}

TEST_F(AlongTrackSim, AViewUnlikeTheTaughtOnesChangesNothing) {
  // A covered lens: flat frames correlate with nothing, so the estimate stays on odometry.
  pf::AlongTrackEstimator estimator(pf::AlongTrackParams{}, taught_);
  const cv::Mat grey(240, 320, CV_8UC3, cv::Scalar(90, 90, 90));
  for (double d = 0.0; d < 10.0; d += 0.05) estimator.update(grey, d);
  EXPECT_EQ(estimator.accepted(), 0);
  EXPECT_EQ(estimator.shift_m(), 0.0);
}

TEST_F(AlongTrackSim, OffWithGainZeroOrWithoutThumbnails) {
  pf::AlongTrackParams off;
  off.gain = 0.0;
  EXPECT_FALSE(pf::AlongTrackEstimator(off, taught_).active());
  EXPECT_FALSE(pf::AlongTrackEstimator(pf::AlongTrackParams{}, {}).active());  // a VPF1 payload
  pf::AlongTrackEstimator none(pf::AlongTrackParams{}, {});
  renderer_->render(pose_at(3.0, 0.0, 0.0), frame_);
  EXPECT_FALSE(none.update(frame_, 2.0));
  EXPECT_EQ(none.shift_m(), 0.0);
}

TEST(AlongTrackParams, OutOfRangeValuesAreRefusedByName) {
  visnav::ConfigNode bad;
  bad.set("along_gain", visnav::ConfigNode::make_scalar("1.5", {"test", 1}));
  auto parsed = pf::AlongTrackParams::schema().parse(bad);
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.error().message.find("along_gain"), std::string::npos) << parsed.error().message;
}

}  // namespace
