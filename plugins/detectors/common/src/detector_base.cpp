// DetectorBase: input checks, grey conversion, adaptive threshold and top-N selection.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "output_buffer.hpp"
#include "visnav/detectors/detector_types.hpp"

namespace visnav::detectors {

namespace {

std::string describe_mat(const cv::Mat& m) {
  static const char* const kDepth[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  const int depth = m.depth();
  std::string t = "CV_" + std::string(depth >= 0 && depth < 8 ? kDepth[depth] : "?") + "C" + std::to_string(m.channels());
  return t + " " + std::to_string(m.cols) + "x" + std::to_string(m.rows);
}

}  // namespace

Status CommonParams::validate_common() const { return adaptive().validate(); }

AdaptiveThresholdParams CommonParams::adaptive() const {
  AdaptiveThresholdParams a;
  a.target_keypoints = target_keypoints;
  a.initial_threshold = threshold;
  a.min_threshold = min_threshold;
  a.max_threshold = max_threshold;
  a.enabled = adaptive_threshold;
  a.exponent = adaptation_exponent;
  a.max_step_ratio = max_step_ratio;
  a.headroom_ratio = headroom_ratio;
  return a;
}

Status DetectorBase::detect(const cv::Mat& image, Features& out) {
  out.keypoints.clear();
  out.norm = norm();
  if (image.empty()) {
    out.descriptors.release();
    return fail(ErrorCode::invalid_value, std::string("detector '") + type_name() + "': empty image");
  }
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3 && image.channels() != 4) ||
      image.dims != 2) {
    out.descriptors.release();
    return fail(ErrorCode::invalid_value, std::string("detector '") + type_name() +
                "': expected an 8-bit grey (CV_8UC1) or BGR (CV_8UC3) image, got " + describe_mat(image));
  }
  const cv::Mat* grey = &image;
  if (image.channels() != 1) {
    cv::cvtColor(image, grey_, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
    grey = &grey_;
  }
  if (grey->cols < kMinImageSidePx || grey->rows < kMinImageSidePx) {
    prepare_output(out.descriptors, 0, 0, CV_8U);
    last_raw_count_ = 0;
    return ok();
  }
  if (keypoints_per_mpx_ > 0.0) {  // the target follows the image area
    const double n = std::round(keypoints_per_mpx_ * grey->cols * static_cast<double>(grey->rows) / 1e6);
    const int target = static_cast<int>(std::clamp(n, 1.0, 20000.0));
    if (target != adaptive_.params().target_keypoints) {
      AdaptiveThresholdParams a = adaptive_.params();
      a.target_keypoints = target;
      adaptive_.reconfigure(a);  // keeps the adapted threshold (initial_threshold unchanged)
    }
  }
  try {
    int raw = 0;
    const int cap = raw_cap();
    auto st = run(*grey, adaptive_.threshold(), out, raw);
    if (!st) {
      out.clear();
      return std::move(st).error().with_context(std::string("detector '") + type_name() + "'");
    }
    last_raw_count_ = raw;
    adaptive_.update(raw, cap);
  } catch (const cv::Exception& e) {
    out.clear();
    return fail(std::string("detector '") + type_name() + "': OpenCV error: " + e.what());
  }
  return ok();
}

void DetectorBase::rank(int n) {
  const int count = static_cast<int>(raw_keypoints_.size());
  order_.resize(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) order_[static_cast<std::size_t>(i)] = i;
  if (n < count) {
    auto stronger = [this](int a, int b) {
      const float ra = raw_keypoints_[static_cast<std::size_t>(a)].response;
      const float rb = raw_keypoints_[static_cast<std::size_t>(b)].response;
      return ra != rb ? ra > rb : a < b;
    };
    std::nth_element(order_.begin(), order_.begin() + n, order_.end(), stronger);
    order_.resize(static_cast<std::size_t>(n));
    std::sort(order_.begin(), order_.end());  // keep the detector's order among the kept ones
  }
}

void DetectorBase::keep_strongest(int n) {
  if (static_cast<int>(raw_keypoints_.size()) <= n) return;
  rank(n);
  kept_.clear();
  for (int i : order_) kept_.push_back(raw_keypoints_[static_cast<std::size_t>(i)]);
  raw_keypoints_.swap(kept_);
}

void DetectorBase::select_strongest(int n, Features& out) {
  rank(std::min(n, static_cast<int>(raw_keypoints_.size())));
  const int m = static_cast<int>(order_.size());
  out.keypoints.clear();
  if (m == 0 || raw_descriptors_.empty()) {
    out.keypoints.clear();
    prepare_output(out.descriptors, 0, 0, CV_8U);
    return;
  }
  prepare_output(out.descriptors, m, raw_descriptors_.cols, raw_descriptors_.type());
  const std::size_t row_bytes = raw_descriptors_.elemSize() * static_cast<std::size_t>(raw_descriptors_.cols);
  for (int j = 0; j < m; ++j) {
    const int i = order_[static_cast<std::size_t>(j)];
    out.keypoints.push_back(raw_keypoints_[static_cast<std::size_t>(i)]);
    std::memcpy(out.descriptors.ptr(j), raw_descriptors_.ptr(i), row_bytes);
  }
}

}  // namespace visnav::detectors
