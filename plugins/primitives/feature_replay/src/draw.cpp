// Alignment picture (see draw.hpp).
#include "visnav/feature_replay/draw.hpp"

#include <algorithm>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace visnav::feature_replay {

namespace {
cv::Mat to_bgr(const cv::Mat& image) {
  cv::Mat out;
  if (image.empty()) return cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(0));
  if (image.channels() == 1) cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  else if (image.channels() == 4) cv::cvtColor(image, out, cv::COLOR_BGRA2BGR);
  else out = image.clone();
  if (out.depth() != CV_8U) out.convertTo(out, CV_8U);
  return out;
}
}  // namespace

cv::Mat render_alignment(const cv::Mat& reference, const cv::Mat& current, const Features& reference_features,
                         const Features& current_features, std::span<const FeatureMatch> matches,
                         std::span<const int> histogram, const HeadingEstimate& estimate, const HeadingParams& params) {
  const cv::Mat a = to_bgr(reference), b = to_bgr(current);
  const int hist_h = 160;
  const int width = a.cols + b.cols;
  const int top_h = std::max(a.rows, b.rows);
  cv::Mat canvas(top_h + hist_h, width, CV_8UC3, cv::Scalar::all(30));
  a.copyTo(canvas(cv::Rect(0, 0, a.cols, a.rows)));
  b.copyTo(canvas(cv::Rect(a.cols, 0, b.cols, b.rows)));
  const cv::Point2f shift(static_cast<float>(a.cols), 0.0f);
  for (const auto& m : matches) {
    if (m.reference_index < 0 || m.current_index < 0) continue;
    if (static_cast<std::size_t>(m.reference_index) >= reference_features.keypoints.size()) continue;
    if (static_cast<std::size_t>(m.current_index) >= current_features.keypoints.size()) continue;
    const cv::Point2f p = reference_features.keypoints[static_cast<std::size_t>(m.reference_index)].pt;
    const cv::Point2f q = current_features.keypoints[static_cast<std::size_t>(m.current_index)].pt + shift;
    const cv::Scalar colour = m.inlier ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 0, 230);
    cv::line(canvas, p, q, colour, 1, cv::LINE_AA);
    cv::circle(canvas, p, 3, colour, 1, cv::LINE_AA);
    cv::circle(canvas, q, 3, colour, 1, cv::LINE_AA);
  }
  // Histogram panel.
  const int bins = static_cast<int>(histogram.size());
  if (bins > 0) {
    const int max_count = std::max(1, *std::max_element(histogram.begin(), histogram.end()));
    const double bar_w = static_cast<double>(width) / bins;
    const int base = top_h + hist_h - 24;
    const double half_range = params.bin_width_px * bins / 2.0;
    for (int i = 0; i < bins; ++i) {
      const int h = static_cast<int>((hist_h - 40) * static_cast<double>(histogram[static_cast<std::size_t>(i)]) / max_count);
      const double lo = i * params.bin_width_px - half_range, hi = lo + params.bin_width_px;
      const bool winning = estimate.matches > 0 && estimate.offset_px >= lo - params.refine_window_px &&
                           estimate.offset_px < hi + params.refine_window_px;
      const cv::Scalar colour = winning ? cv::Scalar(0, 200, 255) : cv::Scalar(200, 200, 200);
      cv::rectangle(canvas, cv::Point(static_cast<int>(i * bar_w) + 1, base - h),
                    cv::Point(static_cast<int>((i + 1) * bar_w) - 1, base), colour, cv::FILLED);
    }
    cv::line(canvas, cv::Point(width / 2, base), cv::Point(width / 2, base + 6), cv::Scalar(255, 255, 255));
  }
  char text[200];
  std::snprintf(text, sizeof text, "offset %.1f px  inliers %d / %d  confidence %.2f%s", estimate.offset_px,
                estimate.inliers, estimate.matches, estimate.confidence, estimate.valid ? "" : "  (not valid)");
  cv::putText(canvas, text, cv::Point(8, top_h + hist_h - 6), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  return canvas;
}

}  // namespace visnav::feature_replay
