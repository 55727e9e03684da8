// The control laws of seed 004 Sec. V (and seed 003's centroid law) against values worked out
// by hand from the paper's formulas.
#include <gtest/gtest.h>

#include <cmath>

#include "visnav/visual_memory/controllers.hpp"

namespace vm = visnav::visual_memory;

namespace {

vm::ControlInput two_points() {
  vm::ControlInput in;
  in.current_norm = {{0.2, 0.1}, {-0.1, 0.3}};
  in.reference_norm = {{0.1, 0.1}, {-0.2, 0.2}};
  in.depth_m = {4.0, 2.0};
  in.speed_mps = 0.3;
  in.camera_forward_m = 0.1;
  return in;
}

double law3(const std::vector<double>& Lv, const std::vector<double>& Lw, const std::vector<double>& e, double lambda,
            double v) {
  double ww = 0, wr = 0;
  for (std::size_t i = 0; i < Lw.size(); ++i) {
    ww += Lw[i] * Lw[i];
    wr += Lw[i] * (lambda * e[i] + Lv[i] * v);
  }
  return -wr / ww;
}

}  // namespace

TEST(VisualMemoryControllers, NamesRoundTripAndUnknownIsRejected) {
  for (const char* n : {"centroid", "RH", "IJP", "IJPU", "IJC", "IJCU", "AIJCA"}) {
    auto c = vm::controller_from_string(n);
    ASSERT_TRUE(c.has_value()) << n;
    EXPECT_STREQ(vm::to_string(*c), n);
  }
  EXPECT_FALSE(vm::controller_from_string("ijc").has_value());
}

TEST(VisualMemoryControllers, IJPStacksThePointJacobians) {
  const auto in = two_points();
  vm::ControlGains g;
  g.lambda = 0.7;
  // L_P,v = (X/z, Y/z), L_P,w = (delta/z + 1 + X^2, XY), e = s - s*.
  const std::vector<double> Lv = {0.2 / 4, 0.1 / 4, -0.1 / 2, 0.3 / 2};
  const std::vector<double> Lw = {0.1 / 4 + 1 + 0.04, 0.02, 0.1 / 2 + 1 + 0.01, -0.03};
  const std::vector<double> e = {0.1, 0.0, 0.1, 0.1};
  const auto out = vm::compute_control(vm::Controller::IJP, in, g);
  ASSERT_TRUE(out.angular_radps.has_value()) << out.reason;
  EXPECT_NEAR(*out.angular_radps, law3(Lv, Lw, e, 0.7, 0.3), 1e-12);
}

TEST(VisualMemoryControllers, IJCUsesTheCentroidAndTheAveragedJacobian) {
  const auto in = two_points();
  vm::ControlGains g;
  g.lambda = 0.7;
  const std::vector<double> Lv = {(0.2 / 4 - 0.1 / 2) / 2, (0.1 / 4 + 0.3 / 2) / 2};
  const std::vector<double> Lw = {((0.1 / 4 + 1 + 0.04) + (0.1 / 2 + 1 + 0.01)) / 2, (0.02 - 0.03) / 2};
  const std::vector<double> e = {0.1, 0.05};
  const auto out = vm::compute_control(vm::Controller::IJC, in, g);
  ASSERT_TRUE(out.angular_radps.has_value()) << out.reason;
  EXPECT_NEAR(*out.angular_radps, law3(Lv, Lw, e, 0.7, 0.3), 1e-12);
}

TEST(VisualMemoryControllers, UniformDepthVariantsIgnoreTheDepthsAndUseZBar) {
  auto in = two_points();
  vm::ControlGains g;
  g.uniform_depth_m = 3.0;
  auto with = in;
  with.depth_m = {3.0, 3.0};
  const auto ijcu = vm::compute_control(vm::Controller::IJCU, in, g);
  const auto ijc = vm::compute_control(vm::Controller::IJC, with, g);
  ASSERT_TRUE(ijcu.angular_radps && ijc.angular_radps);
  EXPECT_NEAR(*ijcu.angular_radps, *ijc.angular_radps, 1e-12);
  in.depth_m.clear();  // IJPU needs none
  const auto ijpu = vm::compute_control(vm::Controller::IJPU, in, g);
  with.depth_m = {3.0, 3.0};
  const auto ijp = vm::compute_control(vm::Controller::IJP, with, g);
  ASSERT_TRUE(ijpu.angular_radps && ijp.angular_radps);
  EXPECT_NEAR(*ijpu.angular_radps, *ijp.angular_radps, 1e-12);
  // IJP without depths: no value, a reason.
  const auto none = vm::compute_control(vm::Controller::IJP, in, g);
  EXPECT_FALSE(none.angular_radps.has_value());
  EXPECT_FALSE(none.reason.empty());
}

TEST(VisualMemoryControllers, AIJCAAndTheCentroidLawSteerAgainstTheAbscissaError) {
  const auto in = two_points();
  vm::ControlGains g;
  g.lambda = 2.0;
  g.centroid_gain_radps = 3.0;
  g.centroid_median = false;
  // features to the right of where the reference has them: the robot looks too far left, turn right
  const auto a = vm::compute_control(vm::Controller::AIJCA, in, g);
  ASSERT_TRUE(a.angular_radps.has_value());
  EXPECT_NEAR(*a.angular_radps, -2.0 * 0.1, 1e-12);
  const auto c = vm::compute_control(vm::Controller::centroid, in, g);
  ASSERT_TRUE(c.angular_radps.has_value());
  EXPECT_NEAR(*c.angular_radps, -3.0 * 0.1, 1e-12);
  // median is robust to one outlier
  auto out = in;
  out.current_norm.push_back({5.0, 0.0});
  out.reference_norm.push_back({0.0, 0.0});
  g.centroid_median = true;
  const auto m = vm::compute_control(vm::Controller::centroid, out, g);
  ASSERT_TRUE(m.angular_radps.has_value());
  EXPECT_NEAR(*m.angular_radps, -3.0 * 0.1, 1e-12);
}

TEST(VisualMemoryControllers, RHNeedsTheRelativeHeading) {
  auto in = two_points();
  vm::ControlGains g;
  g.lambda = 0.5;
  EXPECT_FALSE(vm::compute_control(vm::Controller::RH, in, g).angular_radps.has_value());
  in.heading_change_rad = 0.2;  // turned left of the reference: turn right
  const auto out = vm::compute_control(vm::Controller::RH, in, g);
  ASSERT_TRUE(out.angular_radps.has_value());
  EXPECT_NEAR(*out.angular_radps, -0.1, 1e-12);
}

TEST(VisualMemoryControllers, NoPointsOrBadDepthGiveNoValueNeverNaN) {
  vm::ControlInput in;
  vm::ControlGains g;
  for (auto c : {vm::Controller::centroid, vm::Controller::IJP, vm::Controller::IJPU, vm::Controller::IJC,
                 vm::Controller::IJCU, vm::Controller::AIJCA})
    EXPECT_FALSE(vm::compute_control(c, in, g).angular_radps.has_value()) << vm::to_string(c);
  auto bad = two_points();
  bad.depth_m = {std::nan(""), 2.0};
  EXPECT_FALSE(vm::compute_control(vm::Controller::IJC, bad, g).angular_radps.has_value());
  bad.depth_m = {-1.0, 2.0};
  EXPECT_FALSE(vm::compute_control(vm::Controller::IJP, bad, g).angular_radps.has_value());
}

TEST(VisualMemoryControllers, ImageErrorIsTheMeanPixelDistance) {
  EXPECT_NEAR(vm::image_error_px({{0, 0}, {10, 0}}, {{3, 4}, {10, 2}}), 3.5, 1e-6);
  EXPECT_EQ(vm::image_error_px({}, {}), 0.0);
}
