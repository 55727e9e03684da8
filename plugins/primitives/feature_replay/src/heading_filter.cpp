// Temporal filter of the histogram votes (see heading_filter.hpp).
#include "visnav/feature_replay/heading_filter.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace visnav::feature_replay {

const ParamSchema<HeadingFilterParams>& HeadingFilterParams::schema() {
  static const auto s =
      ParamSchema<HeadingFilterParams>{}
          .field("decay", &HeadingFilterParams::decay, "weight kept from the accumulated histogram per frame")
          .range(0.0, 0.99)
          .field("max_shift_px", &HeadingFilterParams::max_shift_px,
                 "a larger odometric shift between frames restarts the accumulation, px")
          .range(0.0, 10000.0)
          .field("min_votes", &HeadingFilterParams::min_votes, "accumulated votes in the peak for a valid estimate")
          .range(0.0, 1e6)
          .field("full_confidence_votes", &HeadingFilterParams::full_confidence_votes,
                 "accumulated votes at which the count term of the confidence reaches 1")
          .range(1e-3, 1e6)
          .field("min_confidence", &HeadingFilterParams::min_confidence, "filtered estimates below are not valid")
          .range(0.0, 1.0);
  return s;
}

Status HeadingFilterParams::validate() const {
  VISNAV_TRY(schema().check(*this));
  if (full_confidence_votes < min_votes)
    return fail(ErrorCode::inconsistent, ErrorLocation{{}, 0, "full_confidence_votes"},
                "full_confidence_votes (" + std::to_string(full_confidence_votes) + ") must be >= min_votes (" +
                    std::to_string(min_votes) + ")");
  return ok();
}

double shift_px_for_rotation(double rotation_rad, double image_width_px, double horizontal_fov_deg) {
  if (!(image_width_px > 0.0) || !(horizontal_fov_deg > 0.0) || !(horizontal_fov_deg < 180.0)) return 0.0;
  const double focal_px = (image_width_px / 2.0) / std::tan(horizontal_fov_deg * std::numbers::pi / 360.0);
  return focal_px * rotation_rad;
}

int jump_frames(double decay) {
  int k = 1;
  double w = decay;
  while (w >= 0.5 && k < 1000) {
    w *= decay;
    ++k;
  }
  return k;
}

HeadingHistogramFilter::HeadingHistogramFilter(const HeadingFilterParams& params, double bin_width_px, int bin_count)
    : params_(params),
      bin_width_px_(bin_width_px > 0.0 ? bin_width_px : 1.0),
      bin_count_(std::max(1, bin_count)),
      acc_(static_cast<std::size_t>(bin_count_), 0.0),
      scratch_(static_cast<std::size_t>(bin_count_), 0.0) {
  params_.decay = std::clamp(params_.decay, 0.0, 0.99);
}

void HeadingHistogramFilter::reset() {
  std::fill(acc_.begin(), acc_.end(), 0.0);
  empty_ = true;
}

void HeadingHistogramFilter::shift_accumulation(double shift_px) {
  const double b = shift_px / bin_width_px_;
  std::fill(scratch_.begin(), scratch_.end(), 0.0);
  for (int j = 0; j < bin_count_; ++j) {
    const double mass = acc_[static_cast<std::size_t>(j)];
    if (mass == 0.0) continue;
    const double x = j + b;
    const double t0 = std::floor(x);
    const double f = x - t0;
    const int i0 = static_cast<int>(t0);
    if (i0 >= 0 && i0 < bin_count_) scratch_[static_cast<std::size_t>(i0)] += (1.0 - f) * mass;
    if (i0 + 1 >= 0 && i0 + 1 < bin_count_) scratch_[static_cast<std::size_t>(i0 + 1)] += f * mass;
  }
  acc_.swap(scratch_);
}

Result<FilteredHeading> HeadingHistogramFilter::update(std::span<const int> histogram, double predicted_shift_px) {
  if (histogram.size() != acc_.size())
    return fail(ErrorCode::inconsistent, "heading filter: histogram of " + std::to_string(histogram.size()) +
                                             " bins, the filter has " + std::to_string(acc_.size()));
  if (!std::isfinite(predicted_shift_px))
    return fail(ErrorCode::invalid_value, "heading filter: predicted shift is not finite");
  bool restarted = empty_;
  if (!empty_ && std::abs(predicted_shift_px) > params_.max_shift_px) {
    reset();
    restarted = true;
  }
  if (!empty_) {
    shift_accumulation(predicted_shift_px);
    for (double& v : acc_) v *= params_.decay;
  }
  for (std::size_t i = 0; i < acc_.size(); ++i) acc_[i] += histogram[i];
  empty_ = false;
  FilteredHeading out = estimate();
  out.restarted = restarted;
  return out;
}

FilteredHeading HeadingHistogramFilter::estimate() const {
  FilteredHeading e;
  const int bins = bin_count_;
  const int mid = bins / 2;
  int peak = -1;
  for (int i = 0; i < bins; ++i) {
    const double c = acc_[static_cast<std::size_t>(i)];
    if (c <= 0.0) continue;
    if (peak < 0 || c > acc_[static_cast<std::size_t>(peak)] ||
        (c == acc_[static_cast<std::size_t>(peak)] && std::abs(i - mid) < std::abs(peak - mid)))
      peak = i;
  }
  if (peak < 0) return e;
  double mass = 0.0, moment = 0.0;
  for (int i = std::max(0, peak - 1); i <= std::min(bins - 1, peak + 1); ++i) {
    const double c = acc_[static_cast<std::size_t>(i)];
    mass += c;
    moment += c * (i - mid) * bin_width_px_;
  }
  double runner_up = 0.0;
  for (int i = 0; i < bins; ++i)
    if (std::abs(i - peak) >= 2) runner_up = std::max(runner_up, acc_[static_cast<std::size_t>(i)]);
  e.offset_px = moment / mass;
  e.votes = mass;
  e.ambiguity = std::clamp(runner_up / acc_[static_cast<std::size_t>(peak)], 0.0, 1.0);
  const double count_term = std::min(1.0, mass / params_.full_confidence_votes);
  e.confidence = mass < params_.min_votes ? 0.0 : count_term * (1.0 - e.ambiguity);
  e.valid = e.confidence > 0.0 && e.confidence >= params_.min_confidence;
  return e;
}

}  // namespace visnav::feature_replay
