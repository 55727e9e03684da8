// visnav recorded-run helpers — adaptive exposure (seed 002 Sec. 2.2: the acquisition adapts the
// camera exposure to keep images high-contrast under changing illumination).
//
// A multiplicative controller on the mean grey level: after each frame with mean brightness m
// (0..255), exposure ← exposure · (target / m)^gain, the step limited to a factor of
// max_step_ratio either way and the result clamped to [min_exposure, max_exposure]. Within
// ±tolerance of the target nothing changes (no hunting). A black frame (m < 1) counts as m = 1.
// Units are the device's exposure units (V4L2 exposure_time_absolute: 100 µs).
// Pure; no I/O. Thread-safety: one thread per controller.
#pragma once

#include <opencv2/core/mat.hpp>

namespace visnav::recorded {

struct ExposureControlParams {
  double target_brightness = 110.0;  ///< mean grey level to aim at, 0..255
  double tolerance = 8.0;            ///< dead band around the target, grey levels
  double gain = 0.6;                 ///< exponent of the correction (1 = one-step, < 1 damped)
  double max_step_ratio = 2.0;       ///< at most ×/÷ this per frame
  double min_exposure = 1.0;
  double max_exposure = 5000.0;
};

class AdaptiveExposure {
 public:
  AdaptiveExposure(const ExposureControlParams& params, double initial_exposure);
  /// Mean grey level of an 8-bit image (BGR is averaged over channels), subsampled every `step` px.
  [[nodiscard]] static double mean_brightness(const cv::Mat& image, int step = 4);
  /// Feeds one frame's mean brightness; returns the new exposure (may equal the old one).
  double update(double mean_brightness);
  [[nodiscard]] double exposure() const { return exposure_; }

 private:
  ExposureControlParams params_;
  double exposure_;
};

}  // namespace visnav::recorded
