// Step 3 of the IPT cycle alone (spec §11 item 6): RANSAC on F over synthetic matches of the
// thesis rig moving 2 cm, with 20-40 % outliers displaced by more than 5 px and 0.3 px noise.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/ipt_obstacles/pipeline.hpp"

namespace visnav::ipt {
namespace {

struct RansacScore {
  int inliers = 0, inliers_kept = 0;
  int outliers = 0, outliers_removed = 0;
  int outliers_off_line = 0, off_line_removed = 0;  ///< outliers farther than 1 px from their epipolar line
};

/// One synthetic pair: `count` points, a share `ground_share` on the ground 0.7-4 m ahead, the
/// rest on surfaces 1.5-6 m ahead, 0-1.5 m high; the lens drives 2 cm forward and turns 0.3°.
/// A share `outlier_share` of the second frame's points is displaced 5-40 px in a random direction.
/// With odometric_px > 0 the odometry's epipolar check follows RANSAC, the second lens pose
/// read with the given position and heading errors (normal, per pair).
struct OdometryCheck {
  double odometric_px = 0.0;
  double position_sd_m = 0.0;
  double heading_sd_rad = 0.0;
};

RansacScore score_pair(std::mt19937_64& rng, int count, double ground_share, double outlier_share,
                       const OdometryCheck& check = {}) {
  const IptCamera cam = testing::thesis_rig();
  const LensPose first{0.0, 0.0, 0.0};
  const LensPose second{0.02, 0.0, 0.3 * CV_PI / 180.0};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<cv::Point2f> a, b;
  std::vector<bool> is_outlier, off_line;
  const PipelineParams params;
  while (static_cast<int>(a.size()) < count) {
    const bool ground = unit(rng) < ground_share;
    const double x = ground ? 0.7 + 3.3 * unit(rng) : 1.5 + 4.5 * unit(rng);
    const double y = (2.0 * unit(rng) - 1.0) * 0.7 * x;
    const double z = ground ? 0.0 : 1.5 * unit(rng);
    const auto pa = project_point(cam, first, {x, y, z});
    const auto pb = project_point(cam, second, {x, y, z});
    if (!pa || !pb) continue;
    const auto inside = [&](const cv::Point2d& p) { return p.x >= 0 && p.y >= 0 && p.x < cam.width_px && p.y < cam.height_px; };
    if (!inside(*pa) || !inside(*pb)) continue;
    const double na_u = noise(rng);
    const double na_v = noise(rng);
    const double nb_u = noise(rng);
    const double nb_v = noise(rng);
    cv::Point2d qb = *pb + cv::Point2d(nb_u, nb_v);
    const bool outlier = unit(rng) < outlier_share;
    if (outlier) {
      const double angle = 2.0 * CV_PI * unit(rng);
      const double length_px = 5.0 + 35.0 * unit(rng);
      qb += length_px * cv::Point2d(std::cos(angle), std::sin(angle));
    }
    if (outlier) {
      // distance of the displaced point from the true epipolar line: the second view of the
      // first lens's ray through the point (no F can tell an outlier on that line)
      const cv::Vec3d lens(0.0, 0.0, cam.height_m), point(x, y, z);
      const auto near_px = project_point(cam, second, lens + 0.5 * (point - lens));
      const auto far_px = project_point(cam, second, lens + 20.0 * (point - lens));
      if (near_px && far_px) {
        const cv::Point2d d = *far_px - *near_px;
        const double off_px = std::fabs(d.x * (qb.y - near_px->y) - d.y * (qb.x - near_px->x)) / std::hypot(d.x, d.y);
        off_line.push_back(off_px > params.ransac_threshold_px);
      } else {
        off_line.push_back(true);
      }
    } else {
      off_line.push_back(false);
    }
    a.emplace_back(static_cast<float>(pa->x + na_u), static_cast<float>(pa->y + na_v));
    b.emplace_back(static_cast<float>(qb.x), static_cast<float>(qb.y));
    is_outlier.push_back(outlier);
  }
  RansacScore score;
  std::vector<cv::Point2f> ka = a, kb = b;
  std::vector<std::uint8_t> mask;
  PipelineParams checked = params;
  checked.odometry_epipolar_px = check.odometric_px;
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  const double error_x = unit_normal(rng) * check.position_sd_m;
  const double error_y = unit_normal(rng) * check.position_sd_m;
  const double error_heading = unit_normal(rng) * check.heading_sd_rad;
  const OdometryEpipolar motion{cam, first, LensPose{second.x_m + error_x, second.y_m + error_y, second.azimuth_rad + error_heading}};
  const int dropped = reject_epipolar_outliers(ka, kb, checked, mask, &motion);
  EXPECT_EQ(static_cast<std::size_t>(dropped) + ka.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const bool kept = !mask.empty() && mask[i] != 0;
    if (is_outlier[i]) {
      ++score.outliers;
      score.outliers_removed += kept ? 0 : 1;
      if (off_line[i]) {
        ++score.outliers_off_line;
        score.off_line_removed += kept ? 0 : 1;
      }
    } else {
      ++score.inliers;
      score.inliers_kept += kept ? 1 : 0;
    }
  }
  return score;
}

struct Rates {
  double outliers_removed = 0.0, off_line_removed = 0.0, inliers_kept = 0.0;
};

Rates rates(double ground_share, double outlier_share, int trials, const OdometryCheck& check = {}) {
  RansacScore total;
  for (int trial = 0; trial < trials; ++trial) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(1000 * outlier_share + 100 * ground_share) * 131 + trial);
    const RansacScore s = score_pair(rng, 200, ground_share, outlier_share, check);
    total.inliers += s.inliers;
    total.inliers_kept += s.inliers_kept;
    total.outliers += s.outliers;
    total.outliers_removed += s.outliers_removed;
    total.outliers_off_line += s.outliers_off_line;
    total.off_line_removed += s.off_line_removed;
  }
  Rates r;
  r.outliers_removed = static_cast<double>(total.outliers_removed) / total.outliers;
  r.off_line_removed = static_cast<double>(total.off_line_removed) / total.outliers_off_line;
  r.inliers_kept = static_cast<double>(total.inliers_kept) / total.inliers;
  std::printf("ground %.0f %%, outliers %.0f %%: outliers removed %.3f (of those off their epipolar line %.3f, "
              "%d of %d are off it), inliers kept %.3f\n", 100 * ground_share, 100 * outlier_share, r.outliers_removed,
              r.off_line_removed, total.outliers_off_line, total.outliers, r.inliers_kept);
  return r;
}

// The spec's bar (>= 95 % of the outliers removed, >= 90 % of the inliers kept) is not reached
// at the thesis's 2 cm baseline: the flow is a few pixels, so many fundamental matrices fit the
// inliers within 1 px and 6-8 % of the outliers, even those more than 2 px off their true
// epipolar line, fit one of them (docs/obstacles.md, "Other measurements"). These bounds guard
// what OpenCV's RANSAC at the thesis's settings achieves (measured 0.92-0.95 removed, 0.95-0.96 kept).
TEST(IptRansac, RemovesMostOutliersAndKeepsInliersOnANonPlanarScene) {
  for (const double outlier_share : {0.2, 0.3, 0.4}) {
    const Rates r = rates(0.5, outlier_share, 10);
    EXPECT_GE(r.off_line_removed, 0.89) << "outliers " << outlier_share;
    EXPECT_GE(r.inliers_kept, 0.92) << "outliers " << outlier_share;
  }
}

TEST(IptRansac, MostlyGroundScenesFareAsWell) {
  // > 80 % of the points on one plane: a near-degenerate F (spec §11 item 6)
  for (const double outlier_share : {0.2, 0.4}) {
    const Rates r = rates(0.85, outlier_share, 10);
    EXPECT_GE(r.off_line_removed, 0.89) << "outliers " << outlier_share;
    EXPECT_GE(r.inliers_kept, 0.92) << "outliers " << outlier_share;
  }
}

TEST(IptRansac, TheOdometrysEpipolarLineHoldsTrueMatchesAtEveryDepth) {
  const IptCamera cam = testing::thesis_rig();
  const LensPose first{1.0, 2.0, 0.4};
  const LensPose second{1.0 + 0.02 * std::cos(0.41), 2.0 + 0.02 * std::sin(0.41), 0.41};
  const OdometryEpipolar motion{cam, first, second};
  int tested = 0;
  for (const cv::Vec3d& local : {cv::Vec3d(0.8, 0.3, 0.0), cv::Vec3d(3.0, -1.2, 0.0), cv::Vec3d(2.0, 0.5, 1.2),
                                cv::Vec3d(40.0, 10.0, 6.0), cv::Vec3d(1.5, 0.0, 0.2)}) {
    const double c = std::cos(0.4), s = std::sin(0.4);
    const cv::Vec3d p(1.0 + c * local[0] - s * local[1], 2.0 + s * local[0] + c * local[1], local[2]);
    const auto pa = project_point(cam, first, p);
    const auto pb = project_point(cam, second, p);
    ASSERT_TRUE(pa && pb);
    EXPECT_LT(odometry_epipolar_distance_px(motion, *pa, *pb), 0.01) << local[0] << ", " << local[1] << ", " << local[2];
    // the same ray's point ten times nearer lies on the line; 6 px across the line is off it
    const cv::Vec3d lens(first.x_m, first.y_m, cam.height_m);
    const auto nearer = project_point(cam, second, lens + 0.1 * (p - lens));
    ASSERT_TRUE(nearer);
    EXPECT_LT(odometry_epipolar_distance_px(motion, *pa, *nearer), 0.01) << local[0] << ", " << local[1] << ", " << local[2];
    const cv::Point2d along = *nearer - *pb;
    if (cv::norm(along) > 0.5) {
      const cv::Point2d across = cv::Point2d(-along.y, along.x) * (6.0 / cv::norm(along));
      EXPECT_GT(odometry_epipolar_distance_px(motion, *pa, *pb + across), 5.0) << local[0] << ", " << local[1] << ", " << local[2];
      ++tested;
    }
  }
  EXPECT_GE(tested, 4);  // the point straight ahead lies near the epipole, where the line has no direction
}

TEST(IptRansac, TheOdometrysEpipolarLinesRemoveTheOutliersRansacKeeps) {
  // spec §11 item 6 at the thesis's 2 cm: RANSAC alone removes 0.92-0.95 of the outliers off
  // their epipolar line (above); the odometric check after it, with the odometry's pose of the
  // second lens off by 2 mm and 0.05° (a 2 cm step of the simulated robot errs by less), gets
  // past the spec's 95 % and keeps 90 % of the inliers
  const OdometryCheck check{1.5, 0.002, 0.05 * CV_PI / 180.0};
  for (const double ground_share : {0.5, 0.85}) {
    for (const double outlier_share : {0.2, 0.3, 0.4}) {
      const Rates r = rates(ground_share, outlier_share, 10, check);
      EXPECT_GE(r.off_line_removed, 0.95) << "ground " << ground_share << ", outliers " << outlier_share;
      EXPECT_GE(r.inliers_kept, 0.90) << "ground " << ground_share << ", outliers " << outlier_share;
    }
  }
}

TEST(IptRansac, TooFewMatchesDropNothing) {
  std::vector<cv::Point2f> a(7, cv::Point2f(10, 10)), b(7, cv::Point2f(30, 10));
  std::vector<std::uint8_t> mask;
  EXPECT_EQ(reject_epipolar_outliers(a, b, PipelineParams{}, mask), 0);
  EXPECT_EQ(a.size(), 7u);
  std::vector<cv::Point2f> c(9, cv::Point2f(1, 1));
  EXPECT_EQ(reject_epipolar_outliers(a, c, PipelineParams{}, mask), 0);  // sizes differ
}

}  // namespace
}  // namespace visnav::ipt
