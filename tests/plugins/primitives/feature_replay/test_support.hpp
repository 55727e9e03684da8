// Helpers shared by the feature_replay tests: ORB features on real photos, and a synthetic
// scene of 3D points with fixed random descriptors seen through a pinhole camera.
#pragma once

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "visnav/devices.hpp"
#include "visnav/types.hpp"

namespace fr_test {

inline std::string skimage_path(const std::string& name) {
  return "/usr/lib/python3/dist-packages/skimage/data/" + name;
}

inline cv::Mat load_grey(const std::string& name) {
  const auto p = skimage_path(name);
  if (!std::filesystem::exists(p)) return {};
  return cv::imread(p, cv::IMREAD_GRAYSCALE);
}

inline visnav::Features orb_features(const cv::Mat& image, int n = 500) {
  static thread_local cv::Ptr<cv::ORB> orb;
  if (!orb || orb->getMaxFeatures() != n) orb = cv::ORB::create(n);
  visnav::Features f;
  orb->detectAndCompute(image, cv::noArray(), f.keypoints, f.descriptors);
  f.norm = visnav::DescriptorNorm::hamming;
  return f;
}

/// A world of landmarks (x forward, y left, z up; metres) with 32-byte descriptors.
struct SyntheticScene {
  std::vector<cv::Point3d> points;
  cv::Mat descriptors;  // CV_8UC1, 32 columns
  double focal_px = 500.0, width_px = 640.0, height_px = 480.0, camera_height_m = 0.5;

  /// Points scattered around a path: x in [x0, x1], |y| in [min_lateral, max_lateral], z in [0, 3].
  static SyntheticScene around(double x0, double x1, double y0, double y1, int count, unsigned seed = 7,
                               double min_lateral = 2.0, double max_lateral = 12.0) {
    SyntheticScene s;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(x0, x1), uy(min_lateral, max_lateral), uz(0.0, 3.0), side(0, 1);
    std::uniform_real_distribution<double> uy_band(y0, y1);
    s.descriptors.create(count, 32, CV_8UC1);
    for (int i = 0; i < count; ++i) {
      const double lateral = uy(rng) * (side(rng) < 0.5 ? -1.0 : 1.0);
      s.points.emplace_back(ux(rng), uy_band(rng) + lateral, uz(rng));
      for (int j = 0; j < 32; ++j) s.descriptors.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(rng() & 0xff);
    }
    return s;
  }

  /// Features seen from `pose`: projected points in the image, descriptors with `flip_bits` random
  /// bit flips each (appearance noise), optional pixel noise.
  visnav::Features observe(const visnav::Pose2D& pose, std::mt19937& rng, int flip_bits = 8, double pixel_noise = 0.3,
                           double max_range_m = 25.0) const {
    visnav::Features f;
    f.descriptors.create(0, 32, CV_8UC1);
    std::normal_distribution<double> noise(0.0, pixel_noise);
    std::uniform_int_distribution<int> bit(0, 255);
    const double c = std::cos(pose.heading_rad), s = std::sin(pose.heading_rad);
    cv::Mat row(1, 32, CV_8UC1);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double dx = points[i].x - pose.x_m, dy = points[i].y - pose.y_m;
      const double xc = c * dx + s * dy;    // forward
      const double yc = -s * dx + c * dy;   // left
      if (xc < 1.0 || xc > max_range_m) continue;
      const double u = width_px / 2.0 - focal_px * yc / xc + noise(rng);
      const double v = height_px / 2.0 - focal_px * (points[i].z - camera_height_m) / xc + noise(rng);
      if (u < 0 || u >= width_px || v < 0 || v >= height_px) continue;
      f.keypoints.emplace_back(static_cast<float>(u), static_cast<float>(v), 7.0f, -1.0f, 1.0f);
      descriptors.row(static_cast<int>(i)).copyTo(row);
      for (int k = 0; k < flip_bits; ++k) {
        const int b = bit(rng);
        row.at<std::uint8_t>(0, b / 8) ^= static_cast<std::uint8_t>(1u << (b % 8));
      }
      f.descriptors.push_back(row);
    }
    return f;
  }
};

/// Unicycle step.
inline void integrate(visnav::Pose2D& p, const visnav::Twist& t, double dt_s) {
  p.heading_rad += t.angular_radps * dt_s * 0.5;
  p.x_m += t.linear_mps * dt_s * std::cos(p.heading_rad);
  p.y_m += t.linear_mps * dt_s * std::sin(p.heading_rad);
  p.heading_rad += t.angular_radps * dt_s * 0.5;
}

}  // namespace fr_test
