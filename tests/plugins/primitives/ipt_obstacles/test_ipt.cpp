// IPT geometry (spec §11 items 1-3): DPT/IPT round trip, horizon row, blind zone, bad camera.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"

namespace visnav::ipt {
namespace {

using testing::thesis_rig;

// The thesis's printed (4.5) with the typo spec §1.2 names: the y numerator uses
// (y−Y0) cosφ cosθ instead of −(y−Y0) sinφ cosθ.
cv::Point2d project_printed_4_5(const IptCamera& c, const LensPose& lens, const cv::Vec3d& p) {
  const double th = lens.azimuth_rad - CV_PI / 2, ct = std::cos(th), st = std::sin(th);
  const double cp = std::cos(c.pitch_rad), sp = std::sin(c.pitch_rad);
  const double dx = p[0] - lens.x_m, dy = p[1] - lens.y_m, dz = p[2] - c.height_m;
  const double den = -dx * cp * st + dy * cp * ct + dz * sp;
  const double yn = (dx * sp * st + dy * cp * ct + dz * cp) / den;
  const double xn = (dx * ct + dy * st) / den;
  return {c.cx_px + c.fx_px * xn, c.cy_px - c.fy_px * yn};
}

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(IptGeometry, RoundTripOfGroundPointsAtRandomYawAndPitch) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> yaw(-CV_PI, CV_PI), pitch(-30.0, -1.0), fwd(0.7, 6.0), side(-2.0, 2.0);
  IptCamera cam = thesis_rig();
  double worst_m = 0.0, worst_printed_m = 0.0;
  for (int i = 0; i < 2000; ++i) {
    cam.pitch_rad = pitch(rng) * CV_PI / 180.0;
    const LensPose lens{1.5, -2.0, yaw(rng)};
    const double a = fwd(rng), b = side(rng);
    const cv::Vec3d p(lens.x_m + a * std::cos(lens.azimuth_rad) - b * std::sin(lens.azimuth_rad),
                      lens.y_m + a * std::sin(lens.azimuth_rad) + b * std::cos(lens.azimuth_rad), 0.0);
    const auto px = project_point(cam, lens, p);
    ASSERT_TRUE(px.has_value());
    const GroundHit hit = back_project(cam, lens, *px);
    ASSERT_TRUE(hit.valid());
    worst_m = std::max(worst_m, std::hypot(hit.ground_m.x - p[0], hit.ground_m.y - p[1]));
    const GroundHit printed = back_project(cam, lens, project_printed_4_5(cam, lens, p));
    worst_printed_m = std::max(worst_printed_m, printed.valid() ? std::hypot(printed.ground_m.x - p[0], printed.ground_m.y - p[1]) : 1e9);
  }
  EXPECT_LT(worst_m, 1e-9);
  EXPECT_GT(worst_printed_m, 0.1);  // the typo does not survive the round trip
}

TEST(IptGeometry, HorizonRowOfTheThesisRigSplitsPointsAboveAndBelowTheLens) {
  const IptCamera cam = thesis_rig();
  const double v_h = horizon_row_px(cam);
  EXPECT_NEAR(v_h, 64.3, 0.1);
  const LensPose lens{0.0, 0.0, CV_PI / 2};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-1.5, 1.5), y(0.7, 8.0), above(0.44, 3.0);
  for (int i = 0; i < 500; ++i) {
    const auto high = project_point(cam, lens, {x(rng), y(rng), above(rng)});
    ASSERT_TRUE(high.has_value());
    EXPECT_LT(high->y, v_h);
    EXPECT_FALSE(back_project(cam, lens, *high).valid());  // λ* < 0
    const auto low = project_point(cam, lens, {x(rng), y(rng), 0.0});
    ASSERT_TRUE(low.has_value());
    EXPECT_GT(low->y, v_h);
  }
}

TEST(IptGeometry, BottomRowOfTheThesisRigIsTheBlindZone) {
  const IptCamera cam = thesis_rig();
  const LensPose lens{0.0, 0.0, CV_PI / 2};
  const GroundHit hit = back_project(cam, lens, {128.0, 191.5});  // bottom edge of the last row
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.ground_m.x, 0.0, 1e-12);
  EXPECT_NEAR(hit.ground_m.y, 0.625, 0.01);  // spec §1.5/§9.1: 0.625 m from the lens
}

TEST(IptGeometry, LensPoseAndRobotFrame) {
  IptCamera cam = thesis_rig();
  cam.forward_m = 0.2;
  cam.lateral_m = 0.1;
  const Pose2D robot{1.0, 2.0, CV_PI / 2};
  const LensPose lens = lens_pose(cam, robot);
  EXPECT_NEAR(lens.x_m, 0.9, 1e-12);
  EXPECT_NEAR(lens.y_m, 2.2, 1e-12);
  const RangeBearing rb = range_bearing(robot, {0.0, 3.0});  // ahead-left
  EXPECT_NEAR(rb.range_m, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(rb.bearing_rad, CV_PI / 4, 1e-12);
}

TEST(IptGeometry, CameraOutOfRangeOrSeeingNoGroundIsRefusedWithAReason) {
  IptCamera cam = thesis_rig();
  EXPECT_TRUE(cam.validate().ok());
  cam.pitch_rad = 0.45;  // looks up: the horizon falls below the bottom row
  auto st = cam.validate();
  EXPECT_TRUE(fails_with(st, ErrorCode::out_of_range, key_only("pitch_rad")));
  cam = thesis_rig();
  cam.height_m = 0.0;
  st = cam.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::out_of_range);
  cam = thesis_rig();
  cam.pitch_rad = -2.0;  // beyond the schema's [-1.4, 0.5]
  EXPECT_FALSE(cam.validate().ok());
}

}  // namespace
}  // namespace visnav::ipt
