// Along-track estimate from the path edge's thumbnails (along_track.hpp).
#include "visnav/path_following/along_track.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::path_following {

Status AlongTrackParams::validate() const { return schema().check(*this); }

const ParamSchema<AlongTrackParams>& AlongTrackParams::schema() {
  using P = AlongTrackParams;
  static const auto s =
      ParamSchema<P>{}
          .field("along_gain", &P::gain,
                 "along-track correction from the edge's taught thumbnails: share of an accepted innovation "
                 "taken per frame (0 = off: the edge ends on odometry alone)")
          .range(0.0, 1.0)
          .field("along_window_m", &P::window_m, "along-track: taught thumbnails within this of the estimate are compared, m")
          .range(0.25, 20.0)
          .field("along_max_shift_px", &P::max_shift_px, "along-track: horizontal shift search, thumbnail pixels")
          .range(0, 31)
          .field("along_min_ncc", &P::min_ncc, "along-track: correlation the best taught thumbnail must reach")
          .range(-1.0, 1.0)
          .field("along_min_contrast", &P::min_contrast,
                 "along-track: the best correlation must exceed the window's weakest by this")
          .range(0.0, 2.0)
          .field("along_gate_m", &P::gate_m, "along-track: innovations larger than this are ignored, m")
          .range(0.01, 100.0)
          .field("along_max_shift_m", &P::max_shift_m, "along-track: bound on the correction, m")
          .range(0.0, 100.0);
  return s;
}

AlongTrackEstimator::AlongTrackEstimator(const AlongTrackParams& params,
                                         const std::vector<path_payload::Thumbnail>& thumbnails)
    : params_(params) {
  distance_m_.reserve(thumbnails.size());
  references_.reserve(thumbnails.size());
  for (const auto& t : thumbnails) {
    if (t.image.empty() || t.image.type() != CV_8UC1) continue;
    if (!references_.empty() && t.image.size() != references_.front().size()) continue;
    distance_m_.push_back(t.distance_m);
    references_.push_back(path_payload::normalise_thumbnail(t.image));
  }
  if (!references_.empty()) {
    width_px_ = references_.front().cols;
    height_px_ = references_.front().rows;
  }
  scores_.resize(references_.size());
}

bool AlongTrackEstimator::update(const cv::Mat& image, double odometric_m) {
  if (!active()) return false;
  auto thumb = path_payload::make_thumbnail(image, width_px_, height_px_);
  if (!thumb) return false;
  live_u8_ = std::move(*thumb);
  live_ = path_payload::normalise_thumbnail(live_u8_);

  const double estimate_m = odometric_m + shift_m_;
  const auto first = std::lower_bound(distance_m_.begin(), distance_m_.end(), estimate_m - params_.window_m);
  const auto last = std::upper_bound(distance_m_.begin(), distance_m_.end(), estimate_m + params_.window_m);
  const auto lo = static_cast<std::size_t>(first - distance_m_.begin());
  const auto hi = static_cast<std::size_t>(last - distance_m_.begin());  // exclusive
  if (hi < lo + 3) {
    ++rejected_;
    return false;
  }
  std::size_t best = lo;
  double weakest = 2.0;
  for (std::size_t i = lo; i < hi; ++i) {
    double c = -1.0;
    for (int s = -params_.max_shift_px; s <= params_.max_shift_px; ++s)
      c = std::max(c, path_payload::thumbnail_ncc(live_, references_[i], s));
    scores_[i] = c;
    weakest = std::min(weakest, c);
    if (c > scores_[best]) best = i;
  }
  const double peak = scores_[best];
  // At the window's edge the true place may lie outside it; at the edge's ends there is nothing
  // beyond to compare with, so the peak cannot be located either.
  if (best == lo || best + 1 >= hi || peak < params_.min_ncc || peak - weakest < params_.min_contrast) {
    ++rejected_;
    return false;
  }
  // Parabola through the peak and its neighbours (spacing may differ slightly: interpolate in
  // index, then map to distance linearly on the side the vertex falls).
  const double cm = scores_[best - 1];
  const double cp = scores_[best + 1];
  const double denom = cm - 2.0 * peak + cp;
  double offset = denom < -1e-9 ? 0.5 * (cm - cp) / denom : 0.0;
  offset = std::clamp(offset, -0.5, 0.5);
  const double measured_m = offset >= 0.0 ? distance_m_[best] + offset * (distance_m_[best + 1] - distance_m_[best])
                                          : distance_m_[best] + offset * (distance_m_[best] - distance_m_[best - 1]);
  const double innovation = measured_m - estimate_m;
  if (std::abs(innovation) > params_.gate_m) {
    ++rejected_;
    return false;
  }
  last_measurement_m_ = measured_m;
  shift_m_ = std::clamp(shift_m_ + params_.gain * innovation, -params_.max_shift_m, params_.max_shift_m);
  ++accepted_;
  return true;
}

}  // namespace visnav::path_following
