#include "visnav/path_following/stages.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include <opencv2/imgproc.hpp>

namespace visnav::path_following {

namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

cv::Vec3b random_colour(int id, std::uint64_t seed) {
  const std::uint64_t h = splitmix64(static_cast<std::uint64_t>(id) ^ (seed * 0x100000001B3ULL));
  return {static_cast<std::uint8_t>(64 + (h & 0xBF)), static_cast<std::uint8_t>(64 + ((h >> 8) & 0xBF)),
          static_cast<std::uint8_t>(64 + ((h >> 16) & 0xBF))};
}

void title(cv::Mat& panel, const std::string& text, int line = 0) {
  const double scale = std::clamp(panel.cols / 640.0, 0.35, 1.0);
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
  const int y0 = 2 + line * (sz.height + baseline + 4);
  cv::rectangle(panel, cv::Rect(0, y0, sz.width + 6, sz.height + baseline + 4), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(panel, text, cv::Point(3, y0 + sz.height + 2), cv::FONT_HERSHEY_SIMPLEX, scale,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

std::string format(const char* fmt, double a, double b, double c) {
  char buf[160];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

}  // namespace

cv::Mat render_stages(const cv::Mat& bgr, const PathEstimate& estimate, const PathStages& stages,
                      const PathFollowerParams& params, std::uint64_t colour_seed) {
  const int rows = bgr.rows;
  const int cols = bgr.cols;
  const int top = std::clamp(stages.ground_top_px, 0, rows);
  const cv::Rect ground_rect(0, top, cols, rows - top);
  const bool have_labels = !stages.labels.empty() && stages.labels.size() == ground_rect.size();

  // 1: input + horizon.
  cv::Mat input = bgr.clone();
  cv::line(input, cv::Point(0, estimate.horizon.row_px), cv::Point(cols - 1, estimate.horizon.row_px),
           cv::Scalar(0, 0, 255), 1);
  title(input, "1 input + horizon");
  title(input, std::string(estimate.horizon.detected ? "auto row " : "row ") + std::to_string(estimate.horizon.row_px),
        1);

  // 2: superpixels in random colours.
  cv::Mat super(bgr.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  if (have_labels) {
    for (int y = 0; y < ground_rect.height; ++y) {
      const auto* lab = stages.labels.ptr<int>(y);
      auto* dst = super.ptr<cv::Vec3b>(y + top);
      for (int x = 0; x < cols; ++x) dst[x] = random_colour(lab[x], colour_seed);
    }
  }
  title(super, "2 superpixels (" + std::to_string(estimate.segments) + ")");

  // 3: reference region: dimmed input, reference segments at full brightness, trapezoid outline.
  cv::Mat reference;
  cv::addWeighted(bgr, 0.35, cv::Mat::zeros(bgr.size(), bgr.type()), 0.0, 0.0, reference);
  if (have_labels && !stages.segment_is_reference.empty()) {
    for (int y = 0; y < ground_rect.height; ++y) {
      const auto* lab = stages.labels.ptr<int>(y);
      const auto* src = bgr.ptr<cv::Vec3b>(y + top);
      auto* dst = reference.ptr<cv::Vec3b>(y + top);
      for (int x = 0; x < cols; ++x) {
        const auto s = static_cast<std::size_t>(lab[x]);
        if (s < stages.segment_is_reference.size() && stages.segment_is_reference[s] != 0) dst[x] = src[x];
      }
    }
  }
  if (!stages.reference_roi.empty()) {
    std::vector<std::vector<cv::Point>> outline;
    cv::findContours(stages.reference_roi.clone(), outline, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE,
                     cv::Point(0, top));
    cv::polylines(reference, outline, true, cv::Scalar(0, 255, 255), 1);
  }
  title(reference, "3 reference region (" + std::to_string(estimate.reference_models) + " models)");

  // 4: classification mask before opening.
  cv::Mat classification(bgr.size(), CV_8UC3, cv::Scalar(40, 40, 40));
  if (!stages.classified.empty() && stages.classified.size() == ground_rect.size())
    cv::cvtColor(stages.classified, classification(ground_rect), cv::COLOR_GRAY2BGR);
  title(classification, "4 classification");

  // 5: final region, contour, middle points, steering arrow.
  cv::Mat final_panel = bgr.clone();
  if (!estimate.mask.empty() && estimate.mask.size() == bgr.size()) {
    cv::Mat tinted = final_panel.clone();
    tinted.setTo(cv::Scalar(0, 200, 0), estimate.mask);
    cv::addWeighted(final_panel, 0.6, tinted, 0.4, 0.0, final_panel);
  }
  if (!estimate.contour.empty())
    cv::polylines(final_panel, std::vector<std::vector<cv::Point>>{estimate.contour}, true, cv::Scalar(0, 255, 0), 1);
  for (const auto& p : estimate.middle_points)
    cv::circle(final_panel, cv::Point(static_cast<int>(p.x), static_cast<int>(p.y)), 1, cv::Scalar(0, 0, 255),
               cv::FILLED);
  {
    // Arrow from the bottom centre: length ∝ v / max v, turned by ω (ω < 0 = right turn = arrow
    // to the right), 60° at the ω clamp.
    const double v_share = estimate.command.linear_mps > 0.0 ? std::min(1.0, estimate.command.linear_mps / std::max(params.max_linear_mps, 1e-9)) : 0.0;
    const double length = 0.15 * rows + 0.3 * rows * v_share;
    const double max_turn = std::max(params.max_angular_radps, 1e-9);
    const double angle = -std::clamp(estimate.command.angular_radps / max_turn, -1.0, 1.0) * (std::numbers::pi / 3.0);
    const cv::Point start(cols / 2, rows - 2);
    const cv::Point end(static_cast<int>(start.x + length * std::sin(angle)),
                        static_cast<int>(start.y - length * std::cos(angle)));
    cv::arrowedLine(final_panel, start, end,
                    estimate.status == PathStatus::ok ? cv::Scalar(255, 0, 255) : cv::Scalar(128, 128, 128), 2,
                    cv::LINE_AA, 0, 0.2);
  }
  title(final_panel, "5 path: " + std::string(to_string(estimate.status)));
  title(final_panel, format("v=%.2f m/s w=%+.2f rad/s a=%.2f", estimate.command.linear_mps,
                            estimate.command.angular_radps, estimate.area_share),
        1);

  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{input, super, reference, classification, final_panel}, out);
  return out;
}

}  // namespace visnav::path_following
