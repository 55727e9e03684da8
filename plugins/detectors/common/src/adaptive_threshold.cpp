// Adaptive detector threshold — see adaptive_threshold.hpp.
#include "visnav/detectors/adaptive_threshold.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

namespace visnav::detectors {

Status AdaptiveThresholdParams::validate() const {
  if (target_keypoints < 1) return fail("target_keypoints must be >= 1");
  if (!(min_threshold > 0.0)) return fail("min_threshold must be > 0");
  if (!(max_threshold >= min_threshold))
    return fail("max_threshold (" + std::to_string(max_threshold) + ") must be >= min_threshold (" +
                std::to_string(min_threshold) + ")");
  if (!(initial_threshold >= min_threshold && initial_threshold <= max_threshold))
    return fail("threshold " + std::to_string(initial_threshold) + " must lie in [min_threshold, max_threshold] = [" +
                std::to_string(min_threshold) + ", " + std::to_string(max_threshold) + "]");
  if (!(exponent > 0.0 && exponent <= 5.0)) return fail("adaptation_exponent must be in (0, 5]");
  if (!(max_step_ratio > 1.0 && max_step_ratio <= 10.0)) return fail("max_step_ratio must be in (1, 10]");
  if (!(headroom_ratio >= 1.0 && headroom_ratio <= 3.0)) return fail("headroom_ratio must be in [1, 3]");
  return ok();
}

AdaptiveThreshold::AdaptiveThreshold(const AdaptiveThresholdParams& params)
    : params_(params), threshold_(params.initial_threshold) {
  assert(params.validate().ok());
}

void AdaptiveThreshold::reconfigure(const AdaptiveThresholdParams& params) {
  const bool restart = !params.enabled || params.initial_threshold != params_.initial_threshold;
  params_ = params;
  threshold_ = restart ? params.initial_threshold : std::clamp(threshold_, params.min_threshold, params.max_threshold);
  previous_found_ = -1;
  too_many_frame_ = -1;
  too_few_frame_ = -1;
}

int AdaptiveThreshold::aim() const {
  return static_cast<int>(std::ceil(params_.target_keypoints * params_.headroom_ratio - 1e-9));
}

void AdaptiveThreshold::update(int found, int cap) {
  if (!params_.enabled) return;
  ++frame_;
  const double aim_count = aim();
  const bool censored = cap > 0 && found >= cap;
  const bool too_many = censored || found > 1.05 * aim_count;
  const bool too_few = !censored && found < 0.95 * aim_count;
  double factor = 1.0;
  if (censored) {
    factor = params_.max_step_ratio;  // the true count is unknown: no slope from it
  } else if (found <= 0) {
    factor = 1.0 / params_.max_step_ratio;
  } else if (too_many || too_few) {
    double e = params_.exponent;
    if (previous_found_ > 0 && previous_threshold_ > 0.0) {
      const double dlog_t = std::log(threshold_ / previous_threshold_);
      const double dlog_n = std::log(static_cast<double>(found) / previous_found_);
      if (std::abs(dlog_t) > 1e-3) {
        const double alpha = -dlog_n / dlog_t;  // count ∝ threshold^(−α)
        if (std::abs(dlog_n) < 0.02) e = 1.0 / 0.2;  // count did not respond: take the largest step
        else if (alpha > 0.0) e = 1.0 / std::clamp(alpha, 0.2, 5.0);
      }
    }
    factor = std::pow(found / aim_count, e);
  }
  factor = std::clamp(factor, 1.0 / params_.max_step_ratio, params_.max_step_ratio);
  double next = threshold_ * factor;

  // Bracket from recent frames: never step past a threshold known to overshoot the other way;
  // bisect (geometrically) instead. Brackets expire, since the scene changes.
  constexpr int kBracketFrames = 3;
  if (too_many && (too_many_frame_ < 0 || threshold_ >= too_many_at_ || frame_ - too_many_frame_ > kBracketFrames)) {
    too_many_at_ = threshold_;
    too_many_frame_ = frame_;
  }
  if (too_few && (too_few_frame_ < 0 || threshold_ <= too_few_at_ || frame_ - too_few_frame_ > kBracketFrames)) {
    too_few_at_ = threshold_;
    too_few_frame_ = frame_;
  }
  const bool few_known = too_few_frame_ >= 0 && frame_ - too_few_frame_ <= kBracketFrames;
  const bool many_known = too_many_frame_ >= 0 && frame_ - too_many_frame_ <= kBracketFrames;
  if (too_many && few_known && too_few_at_ > threshold_ && next >= too_few_at_) next = std::sqrt(threshold_ * too_few_at_);
  if (too_few && many_known && too_many_at_ < threshold_ && next <= too_many_at_) next = std::sqrt(threshold_ * too_many_at_);

  previous_threshold_ = threshold_;
  previous_found_ = censored ? -1 : found;
  threshold_ = std::clamp(next, params_.min_threshold, params_.max_threshold);
}

}  // namespace visnav::detectors
