// Synthetic path scenes for the path-following tests and benchmark: a light sky above a
// horizon row, green noisy "grass" with darker blotches below it, and a textured grey "gravel"
// band whose centre and half-width are functions of the row (perspective: narrow at the
// horizon, wide at the bottom). Deterministic for a given seed.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace visnav::path_following::testing {

struct Scene {
  cv::Mat bgr;    ///< CV_8UC3
  cv::Mat truth;  ///< CV_8UC1, 255 on the gravel band
  int horizon_row = 0;
};

struct SceneSpec {
  int width = 320;
  int height = 240;
  int horizon_row = 72;
  /// Band centre column at a row, as a function of depth t ∈ [0, 1] (0 = horizon, 1 = bottom).
  std::function<double(double t)> centre_px = [](double) { return 160.0; };
  double half_width_far_px = 12.0;   ///< at the horizon
  double half_width_near_px = 80.0;  ///< at the bottom row
  cv::Vec3b grass{40, 140, 60};      ///< BGR
  cv::Vec3b gravel{150, 152, 155};
  cv::Vec3b sky{235, 205, 170};
  double grass_noise = 14.0;   ///< per-channel std
  double gravel_noise = 22.0;  ///< luminance std (grey texture)
  bool draw_band = true;
  std::uint32_t seed = 1;
};

inline std::uint8_t sat(double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

inline Scene make_scene(const SceneSpec& s) {
  Scene out;
  out.horizon_row = s.horizon_row;
  out.bgr.create(s.height, s.width, CV_8UC3);
  out.truth = cv::Mat::zeros(s.height, s.width, CV_8UC1);
  std::mt19937 rng(s.seed);
  std::normal_distribution<double> n01(0.0, 1.0);

  // Grass blotches: a low-frequency darkening field so grass is not a flat colour.
  cv::Mat blotch(s.height / 8 + 1, s.width / 8 + 1, CV_32F);
  for (int y = 0; y < blotch.rows; ++y)
    for (int x = 0; x < blotch.cols; ++x) blotch.at<float>(y, x) = static_cast<float>(0.85 + 0.15 * n01(rng));
  cv::resize(blotch, blotch, cv::Size(s.width, s.height), 0, 0, cv::INTER_LINEAR);

  const double ground_rows = std::max(1, s.height - 1 - s.horizon_row);
  for (int y = 0; y < s.height; ++y) {
    auto* px = out.bgr.ptr<cv::Vec3b>(y);
    auto* gt = out.truth.ptr<std::uint8_t>(y);
    const double t = std::clamp((y - s.horizon_row) / ground_rows, 0.0, 1.0);
    const double c = s.centre_px(t);
    const double hw = s.half_width_far_px + (s.half_width_near_px - s.half_width_far_px) * t;
    for (int x = 0; x < s.width; ++x) {
      if (y < s.horizon_row) {
        const double shade = 1.0 - 0.15 * y / std::max(1, s.horizon_row);
        for (int ch = 0; ch < 3; ++ch) px[x][ch] = sat(s.sky[ch] * shade + 3.0 * n01(rng));
        continue;
      }
      const bool on_band = s.draw_band && std::abs((x + 0.5) - c) <= hw;
      if (on_band) {
        gt[x] = 255;
        const double l = s.gravel_noise * n01(rng);
        for (int ch = 0; ch < 3; ++ch) px[x][ch] = sat(s.gravel[ch] + l + 3.0 * n01(rng));
      } else {
        const double b = blotch.at<float>(y, x);
        for (int ch = 0; ch < 3; ++ch) px[x][ch] = sat(s.grass[ch] * b + s.grass_noise * n01(rng));
      }
    }
  }
  return out;
}

/// IoU of two binary masks (non-zero = set), restricted to rows ≥ first_row.
inline double mask_iou(const cv::Mat& a, const cv::Mat& b, int first_row = 0) {
  const cv::Rect r(0, first_row, a.cols, a.rows - first_row);
  cv::Mat ab, aob;
  cv::bitwise_and(a(r) != 0, b(r) != 0, ab);
  cv::bitwise_or(a(r) != 0, b(r) != 0, aob);
  const double u = cv::countNonZero(aob);
  return u > 0 ? cv::countNonZero(ab) / u : 1.0;
}

}  // namespace visnav::path_following::testing
