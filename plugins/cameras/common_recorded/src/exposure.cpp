// Adaptive exposure controller (exposure.hpp).
#include "visnav/recorded/exposure.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::recorded {

AdaptiveExposure::AdaptiveExposure(const ExposureControlParams& params, double initial_exposure)
    : params_(params), exposure_(std::clamp(initial_exposure, params.min_exposure, params.max_exposure)) {}

double AdaptiveExposure::mean_brightness(const cv::Mat& image, int step) {
  if (image.empty() || image.depth() != CV_8U) return 0.0;
  step = std::max(1, step);
  const int channels = image.channels();
  double sum = 0.0;
  std::size_t n = 0;
  for (int r = 0; r < image.rows; r += step) {
    const std::uint8_t* row = image.ptr<std::uint8_t>(r);
    for (int c = 0; c < image.cols; c += step) {
      const std::uint8_t* px = row + static_cast<std::size_t>(c) * channels;
      int s = 0;
      for (int k = 0; k < std::min(channels, 3); ++k) s += px[k];
      sum += static_cast<double>(s) / std::min(channels, 3);
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

double AdaptiveExposure::update(double mean_brightness) {
  const double m = std::max(1.0, mean_brightness);
  if (std::abs(m - params_.target_brightness) <= params_.tolerance) return exposure_;
  double ratio = std::pow(params_.target_brightness / m, params_.gain);
  ratio = std::clamp(ratio, 1.0 / params_.max_step_ratio, params_.max_step_ratio);
  exposure_ = std::clamp(exposure_ * ratio, params_.min_exposure, params_.max_exposure);
  return exposure_;
}

}  // namespace visnav::recorded
