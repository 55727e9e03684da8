// visnav detectors — adaptive detector threshold (seed 002 Sec. 2.2: "actively adapting ...
// the Hessian threshold ... to extract the desired number of image features").
//
// Every detector has one threshold where a higher value gives fewer keypoints (FAST/AGAST
// intensity difference, STAR response, SIFT contrast, GFTT quality, ...). After each frame,
// `update(found)` moves it multiplicatively toward the value that would have produced
//     aim = ceil(target_keypoints × headroom_ratio)
// raw keypoints: threshold ← threshold · (found / aim)^e, where e = 1/α and α is the local
// slope −d log(count)/d log(threshold), estimated from the last two frames (secant in log-log
// space, clamped to [0.2, 5]; a count that did not move counts as α = 0.2) and `exponent` until
// two usable frames exist. The factor per
// frame is clamped to [1/max_step_ratio, max_step_ratio], the threshold to
// [min_threshold, max_threshold]; within ±5 % of the aim nothing changes (no jitter). A frame
// without keypoints divides by max_step_ratio, a count that hit the detector's own cap multiplies
// by it. A step never crosses a threshold that overshot the other way within the last 3 frames;
// it bisects (geometric mean) instead. The detector then keeps the target_keypoints
// strongest responses, so aiming slightly above the target yields a steady output count.
//
// Thread-safety: plain value type. Units: those of the detector's threshold.
#pragma once

#include "visnav/result.hpp"

namespace visnav::detectors {

struct AdaptiveThresholdParams {
  int target_keypoints = 500;   ///< keypoints wanted per frame, ≥ 1
  double initial_threshold = 1; ///< start value, within [min_threshold, max_threshold]
  double min_threshold = 0.1;   ///< > 0
  double max_threshold = 100;
  bool enabled = true;          ///< false: the threshold stays at initial_threshold
  double exponent = 0.5;        ///< e used before the slope is known, (0, 5]
  double max_step_ratio = 2.0;  ///< max factor per frame, (1, 10]
  double headroom_ratio = 1.2;  ///< aim = target × this, [1, 3]

  [[nodiscard]] Status validate() const;
};

class AdaptiveThreshold {
 public:
  /// `params` must satisfy validate() (asserted).
  explicit AdaptiveThreshold(const AdaptiveThresholdParams& params = {});

  /// Applies new parameters. The current threshold is kept (clamped to the new range) unless
  /// `initial_threshold` changed or adaptation is off, in which case it restarts there.
  void reconfigure(const AdaptiveThresholdParams& params);

  [[nodiscard]] double threshold() const { return threshold_; }
  [[nodiscard]] int aim() const;
  [[nodiscard]] const AdaptiveThresholdParams& params() const { return params_; }

  /// Feeds the raw keypoint count the current threshold produced on the last frame.
  /// `cap` > 0: the detector stops at `cap` keypoints itself, so found ≥ cap only says "too
  /// many" — the threshold then rises by max_step_ratio and the slope estimate restarts.
  void update(int found, int cap = 0);

 private:
  AdaptiveThresholdParams params_;
  double threshold_;
  double previous_threshold_ = 0.0;
  int previous_found_ = -1;
  long frame_ = 0;
  double too_many_at_ = 0.0;  ///< largest recent threshold that gave too many keypoints
  long too_many_frame_ = -1;
  double too_few_at_ = 0.0;   ///< smallest recent threshold that gave too few
  long too_few_frame_ = -1;
};

}  // namespace visnav::detectors
