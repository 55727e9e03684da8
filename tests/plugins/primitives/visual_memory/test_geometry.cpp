// Local geometry of the visual memory (seed 003 Sec. II-A): 5-point essential matrix with the
// odometric scale, triangulation, PnP, and the degenerate inputs (fewer than 5
// correspondences, pure rotation, a planar scene) on synthetic correspondences.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "visnav/visual_memory/geometry.hpp"

namespace vm = visnav::visual_memory;

namespace {

const vm::Intrinsics kK = vm::Intrinsics::from_fov(320, 240, 60.0);

/// Camera yawed left (counter-clockwise seen from above) by `yaw_rad`: X_cam = R X_ref + t.
cv::Matx33d yaw_left(double yaw_rad) {
  return {std::cos(yaw_rad), 0, std::sin(yaw_rad), 0, 1, 0, -std::sin(yaw_rad), 0, std::cos(yaw_rad)};
}

cv::Point2f pixel(const cv::Vec3d& p) {
  return {static_cast<float>(kK.focal_px * p[0] / p[2] + kK.cx_px), static_cast<float>(kK.focal_px * p[1] / p[2] + kK.cy_px)};
}

struct Scene {
  std::vector<cv::Vec3d> points;  // first view's frame
  std::vector<cv::Point2f> first, second;
};

/// Points 3-15 m ahead (or on the plane z = 8 when planar), seen by a first camera at the
/// origin and a second one moved by (R, t); pixel noise sigma_px.
Scene make_scene(const cv::Matx33d& R, const cv::Vec3d& t, bool planar, double sigma_px, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), depth(3.0, 15.0);
  std::normal_distribution<double> noise(0.0, sigma_px);
  Scene s;
  while (s.points.size() < 120) {
    const double z = planar ? 8.0 : depth(rng);
    const cv::Vec3d p(u(rng) * 0.5 * z, u(rng) * 0.35 * z, z);
    const cv::Vec3d q = R * p + t;
    if (q[2] < 1.0) continue;
    cv::Point2f a = pixel(p), b = pixel(q);
    if (b.x < 0 || b.y < 0 || b.x > 319 || b.y > 239 || a.x < 0 || a.y < 0 || a.x > 319 || a.y > 239) continue;
    a += cv::Point2f(static_cast<float>(noise(rng)), static_cast<float>(noise(rng)));
    b += cv::Point2f(static_cast<float>(noise(rng)), static_cast<float>(noise(rng)));
    s.points.push_back(p);
    s.first.push_back(a);
    s.second.push_back(b);
  }
  return s;
}

}  // namespace

TEST(VisualMemoryGeometry, RecoversTheMetricRelativePoseAndTriangulatesWithTheOdometricScale) {
  // The second camera drove 1.0 m forward while turning 5 degrees left.
  const double yaw = 5.0 * std::numbers::pi / 180.0;
  const cv::Matx33d R = yaw_left(yaw);
  const cv::Vec3d centre(-0.05, 0.0, 1.0);                // second camera centre in the first frame
  const cv::Vec3d c = centre * (1.0 / cv::norm(centre));  // 1 m baseline
  const cv::Vec3d t = -(R * c);
  const Scene s = make_scene(R, t, false, 0.3);
  const vm::RelativeGeometry g = vm::relative_geometry(s.first, s.second, kK, 1.0, vm::GeometryParams{});
  ASSERT_EQ(g.status, vm::GeometryStatus::ok) << vm::to_string(g.status);
  EXPECT_NEAR(std::atan2(g.R(0, 2), g.R(2, 2)), yaw, 0.01);
  EXPECT_NEAR(cv::norm(g.t_m), 1.0, 1e-9);
  EXPECT_LT(cv::norm(g.t_m - t), 0.05);
  EXPECT_LT(g.rms_error_px, 1.0);
  int made = 0;
  std::vector<double> rel;
  for (std::size_t j = 0; j < s.points.size(); ++j) {
    if (!g.has_3d[j]) continue;
    ++made;
    const cv::Vec3d truth = R * s.points[j] + t;
    const cv::Vec3d got(g.points_m[j].x, g.points_m[j].y, g.points_m[j].z);
    rel.push_back(cv::norm(got - truth) / truth[2]);
  }
  EXPECT_GT(made, 60);
  std::sort(rel.begin(), rel.end());
  // 0.3 px noise, 1 m baseline, points 3-15 m ahead: depth is poor near the epipole only
  EXPECT_LT(rel[rel.size() / 2], 0.08);
  EXPECT_LT(rel[rel.size() * 9 / 10], 0.25);
}

TEST(VisualMemoryGeometry, FewerThanFiveCorrespondencesIsReportedNotComputed) {
  const Scene s = make_scene(cv::Matx33d::eye(), cv::Vec3d(0, 0, -1), false, 0.0);
  std::vector<cv::Point2f> a(s.first.begin(), s.first.begin() + 4), b(s.second.begin(), s.second.begin() + 4);
  const vm::RelativeGeometry g = vm::relative_geometry(a, b, kK, 1.0, vm::GeometryParams{});
  EXPECT_EQ(g.status, vm::GeometryStatus::too_few_correspondences);
  EXPECT_EQ(g.has_3d.size(), 4u);
  for (auto h : g.has_3d) EXPECT_EQ(h, 0);
}

TEST(VisualMemoryGeometry, PureRotationGivesNoBaselineAndNoPoints) {
  const Scene s = make_scene(yaw_left(0.1), cv::Vec3d(0, 0, 0), false, 0.2);
  const vm::RelativeGeometry g = vm::relative_geometry(s.first, s.second, kK, 0.0, vm::GeometryParams{});
  EXPECT_EQ(g.status, vm::GeometryStatus::no_baseline);
  for (auto h : g.has_3d) EXPECT_EQ(h, 0);
  EXPECT_TRUE(std::isfinite(g.rms_error_px));
  for (double v : g.R.val) EXPECT_TRUE(std::isfinite(v));
}

TEST(VisualMemoryGeometry, PlanarSceneGivesFiniteOutputOrADegenerateStatus) {
  const Scene s = make_scene(yaw_left(0.02), cv::Vec3d(0.02, 0, -0.8), true, 0.3);
  const vm::RelativeGeometry g = vm::relative_geometry(s.first, s.second, kK, 0.8, vm::GeometryParams{});
  for (double v : g.R.val) EXPECT_TRUE(std::isfinite(v));
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(std::isfinite(g.t_m[i]));
  for (std::size_t j = 0; j < g.has_3d.size(); ++j)
    if (g.has_3d[j]) {
      EXPECT_TRUE(std::isfinite(g.points_m[j].z));
      EXPECT_GT(g.points_m[j].z, 0.0f);
    }
  // Either a usable reconstruction (the 5-point algorithm copes with planes) or a status.
  if (g.status == vm::GeometryStatus::ok) {
    EXPECT_LT(std::abs(std::atan2(g.R(0, 2), g.R(2, 2)) - 0.02), 0.05);
  }
}

TEST(VisualMemoryGeometry, PnPRecoversThePoseAndItsHeadingChange) {
  const double yaw = -0.15;  // turned right
  const cv::Matx33d R = yaw_left(yaw);
  const cv::Vec3d t(0.3, 0.0, -1.2);
  const Scene s = make_scene(R, t, false, 0.2);
  std::vector<cv::Point3f> p3;
  for (const auto& p : s.points) p3.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2]));
  const vm::PoseEstimate pose = vm::estimate_pose(p3, s.second, kK, 6, 3.0);
  ASSERT_TRUE(pose.ok);
  EXPECT_NEAR(pose.heading_change_rad(), yaw, 0.01);
  EXPECT_LT(cv::norm(pose.t_m - t), 0.05);
  const cv::Vec3d c = pose.position_in_reference_m();
  const cv::Vec3d c_true = -(R.t() * t);
  EXPECT_LT(cv::norm(c - c_true), 0.05);
  // Too few points: no pose, nothing non-finite.
  std::vector<cv::Point3f> few(p3.begin(), p3.begin() + 3);
  std::vector<cv::Point2f> few2(s.second.begin(), s.second.begin() + 3);
  EXPECT_FALSE(vm::estimate_pose(few, few2, kK, 6, 3.0).ok);
}

TEST(VisualMemoryGeometry, ProjectRejectsPointsBehindTheCamera) {
  vm::PoseEstimate pose;
  pose.ok = true;
  cv::Point2f px;
  EXPECT_TRUE(vm::project(pose, cv::Point3f(0, 0, 5), kK, px));
  EXPECT_NEAR(px.x, kK.cx_px, 1e-4);
  EXPECT_FALSE(vm::project(pose, cv::Point3f(0, 0, -5), kK, px));
}

TEST(VisualMemoryGeometry, EveryEstimatorIncludingMLESACRejectsThirtyPercentOutliers) {
  const double yaw = 0.05;
  const cv::Matx33d R = yaw_left(yaw);
  const cv::Vec3d c = cv::Vec3d(0.1, 0.0, 1.0) * (1.0 / cv::norm(cv::Vec3d(0.1, 0.0, 1.0)));
  const cv::Vec3d t = -(R * c);
  Scene s = make_scene(R, t, false, 0.3, 11);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> ux(0.0f, 319.0f), uy(0.0f, 239.0f);
  std::vector<bool> outlier(s.second.size(), false);
  for (std::size_t j = 0; j < s.second.size(); j += 3) {  // every third: a random pixel
    s.second[j] = cv::Point2f(ux(rng), uy(rng));
    outlier[j] = true;
  }
  for (const char* estimator : {"ransac", "lmeds", "magsac", "mlesac"}) {
    vm::GeometryParams p;
    p.estimator = estimator;
    const vm::RelativeGeometry g = vm::relative_geometry(s.first, s.second, kK, 1.0, p);
    ASSERT_EQ(g.status, vm::GeometryStatus::ok) << estimator << ": " << vm::to_string(g.status);
    EXPECT_NEAR(std::atan2(g.R(0, 2), g.R(2, 2)), yaw, 0.01) << estimator;
    EXPECT_LT(cv::norm(g.t_m - t), 0.1) << estimator;
    int outliers_in_3d = 0, made = 0;
    for (std::size_t j = 0; j < outlier.size(); ++j) {
      made += g.has_3d[j];
      outliers_in_3d += g.has_3d[j] && outlier[j];
    }
    EXPECT_GT(made, 40) << estimator;
    EXPECT_LE(outliers_in_3d, 2) << estimator;
  }
}
