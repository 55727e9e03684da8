// Map style A: segment teacher and replayer (see segment_map.hpp; the payload codec is the SDK's,
// runtime/src/map/feature_payloads.cpp).
#include "visnav/feature_replay/segment_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>
#include <string>

#include <opencv2/core.hpp>

namespace visnav::feature_replay {

namespace {
constexpr double kCapWindowM = 0.5;

std::size_t row_bytes(int cols, int type) { return static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type); }
}  // namespace

// ---------------------------------------------------------------- params ----

const ParamSchema<SegmentTeachParams>& SegmentTeachParams::schema() {
  static const auto s =
      ParamSchema<SegmentTeachParams>{}
          .field("track_ratio", &SegmentTeachParams::track_ratio, "ratio test when matching tracked landmarks (1 = off)")
          .range(0.1, 1.0)
          .field("max_track_step_px", &SegmentTeachParams::max_track_step_px,
                 "max image motion of a tracked landmark between consecutive frames, px")
          .range(1.0, 10000.0)
          .field("max_descriptor_distance", &SegmentTeachParams::max_descriptor_distance,
                 "absolute descriptor distance gate for tracking; 0 = off")
          .range(0.0, 1e6)
          .field("min_observations", &SegmentTeachParams::min_observations, "frames a landmark must be seen in to be kept")
          .range(1, 100000)
          .field("min_track_length_m", &SegmentTeachParams::min_track_length_m,
                 "distance over which a landmark must be tracked to be kept, m")
          .range(0.0, 1000.0)
          .field("max_landmarks_per_m", &SegmentTeachParams::max_landmarks_per_m,
                 "landmark density cap (highest observation count kept)")
          .range(1.0, 100000.0);
  return s;
}

const ParamSchema<SegmentReplayParams>& SegmentReplayParams::schema() {
  static const auto s =
      ParamSchema<SegmentReplayParams>{}
          .field("speed_mps", &SegmentReplayParams::speed_mps, "constant forward speed, m/s")
          .range(-5.0, 5.0)
          .field("gain_radps_per_px", &SegmentReplayParams::gain_radps_per_px,
                 "steering gain: omega = -gain * offset_px, rad/s per px")
          .range(0.0, 1.0)
          .field("max_angular_radps", &SegmentReplayParams::max_angular_radps, "clamp of |omega|, rad/s")
          .range(0.0, 10.0)
          .field("distance_margin_m", &SegmentReplayParams::distance_margin_m,
                 "widen each landmark's visibility window [f, g] by this much, m")
          .range(0.0, 100.0)
          .field("along_gain", &SegmentReplayParams::along_gain,
                 "along-track correction: share of the estimated along-track error applied per frame (0 = off)")
          .range(0.0, 1.0)
          .field("max_along_step_m", &SegmentReplayParams::max_along_step_m,
                 "along-track correction: clamp of one frame's step, m")
          .range(0.0, 10.0)
          .field("max_along_correction_m", &SegmentReplayParams::max_along_correction_m,
                 "along-track correction: clamp of the total over one segment, m")
          .range(0.0, 100.0)
          .field("along_window_px", &SegmentReplayParams::along_window_px,
                 "along-track correction: matches within this of the winning offset take part, px")
          .range(1.0, 1000.0)
          .field("along_max_offset_px", &SegmentReplayParams::along_max_offset_px,
                 "along-track correction: updated only while |offset| (the heading error seen) is at most this, px")
          .range(0.0, 10000.0)
          .field("min_along_matches", &SegmentReplayParams::min_along_matches,
                 "along-track correction: fewer matches give no estimate")
          .range(3, 100000)
          .field("min_along_slope_px_per_m", &SegmentReplayParams::min_along_slope_px_per_m,
                 "along-track correction: the matches' slope spread (root of the summed squared centred slopes) "
                 "below this gives no estimate, px/m")
          .range(0.0, 1e6)
          .field("along_end_window_m", &SegmentReplayParams::along_end_window_m,
                 "along-track correction, end window (used instead of along_gain when > 0): only the estimates of "
                 "the segment's last this many metres count; their mean is the correction once they pass the count "
                 "and spread gates, m (0 = off)")
          .range(0.0, 100.0)
          .field("along_min_frames", &SegmentReplayParams::along_min_frames,
                 "along-track correction, end window: fewer estimates give no correction")
          .range(1, 100000)
          .field("along_max_sd_m", &SegmentReplayParams::along_max_sd_m,
                 "along-track correction, end window: estimates with a larger standard deviation give no correction, m")
          .range(0.0, 100.0)
          .field("temporal_decay", &SegmentReplayParams::temporal_decay,
                 "temporal filter: weight kept per frame from the earlier frames' votes, shifted by the odometric "
                 "rotation since (0 = off: each frame on its own)")
          .range(0.0, 0.99)
          .field("temporal_hold_m", &SegmentReplayParams::temporal_hold_m,
                 "temporal filter: the filtered offset steers only within this distance after the last frame whose "
                 "own estimate was confident, m")
          .range(0.0, 1000.0);
  return s;
}

// ---------------------------------------------------------------- teacher ----

SegmentTeacher::SegmentTeacher(const SegmentTeachParams& params) : params_(params) {}

void SegmentTeacher::begin(double azimuth_rad) {
  azimuth_rad_ = azimuth_rad;
  last_distance_m_ = 0.0;
  desc_type_ = -1;
  desc_cols_ = 0;
  tracks_.clear();
  done_.clear();
  done_desc_.clear();
}

void SegmentTeacher::ensure_track_capacity(int rows, int cols, int type) {
  if (track_desc_.rows >= rows && track_desc_.cols == cols && track_desc_.type() == type) return;
  const int capacity = std::max(rows, std::max(64, track_desc_.rows * 2));
  cv::Mat bigger(capacity, cols, type);
  const int live = static_cast<int>(tracks_.size());
  if (live > 0 && track_desc_.cols == cols && track_desc_.type() == type)
    track_desc_.rowRange(0, live).copyTo(bigger.rowRange(0, live));
  track_desc_ = bigger;
  next_desc_.create(capacity, cols, type);
}

void SegmentTeacher::close_track(std::size_t i) {
  const Track& t = tracks_[i];
  if (static_cast<int>(t.count) < params_.min_observations) return;
  if (static_cast<double>(t.last_m) - t.first_m < params_.min_track_length_m) return;
  done_.push_back(Landmark{t.count, t.first_px, t.last_px, t.first_m, t.last_m});
  const std::uint8_t* row = track_desc_.ptr(static_cast<int>(i));
  done_desc_.insert(done_desc_.end(), row, row + row_bytes(desc_cols_, desc_type_));
}

Status SegmentTeacher::add_frame(double distance_m, const Features& features) {
  VISNAV_TRY(check_features(features, "teach features"));
  if (!std::isfinite(distance_m)) return fail("teach distance is not finite");
  const double d = std::max(distance_m, last_distance_m_);
  last_distance_m_ = d;
  const cv::Mat& cur = features.descriptors;
  const int n_cur = static_cast<int>(features.keypoints.size());
  if (n_cur > 0) {
    if (desc_type_ < 0) {
      desc_type_ = cur.type();
      desc_cols_ = cur.cols;
    } else if (cur.type() != desc_type_ || cur.cols != desc_cols_) {
      return fail("teach features: descriptor type/width changed during the segment (" + std::to_string(cur.cols) +
                  " columns of type " + std::to_string(cur.type()) + ", expected " + std::to_string(desc_cols_) +
                  " of type " + std::to_string(desc_type_) + ")");
    }
  }
  const int n_tracks = static_cast<int>(tracks_.size());
  used_.assign(static_cast<std::size_t>(n_cur), 0);
  next_tracks_.clear();
  if (n_tracks > 0 || n_cur > 0) ensure_track_capacity(n_tracks + n_cur, desc_cols_, desc_type_);
  int next_rows = 0;
  const std::size_t rb = desc_type_ < 0 ? 0 : row_bytes(desc_cols_, desc_type_);
  auto keep = [&](const Track& t, const std::uint8_t* desc_row) {
    std::memcpy(next_desc_.ptr(next_rows), desc_row, rb);
    next_tracks_.push_back(t);
    ++next_rows;
  };

  if (n_tracks > 0 && n_cur > 0) {
    const cv::Mat live = track_desc_.rowRange(0, n_tracks);
    knn2_bruteforce(live, cur, best_, best_d_, second_d_, &cur_best_, &cur_best_d_);
    const float ratio = static_cast<float>(params_.track_ratio);
    const double step2 = params_.max_track_step_px * params_.max_track_step_px;
    for (int i = 0; i < n_tracks; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const int j = best_[ui];
      bool matched = j >= 0;
      if (matched && ratio < 1.0f && std::isfinite(second_d_[ui]) && !(best_d_[ui] < ratio * second_d_[ui])) matched = false;
      if (matched && params_.max_descriptor_distance > 0.0 && best_d_[ui] > params_.max_descriptor_distance) matched = false;
      if (matched && cur_best_[static_cast<std::size_t>(j)] != i) matched = false;
      if (matched) {
        const cv::Point2f p = features.keypoints[static_cast<std::size_t>(j)].pt;
        const cv::Point2f q = tracks_[ui].last_px;
        const double dx = p.x - q.x, dy = p.y - q.y;
        if (!(dx * dx + dy * dy <= step2)) matched = false;
      }
      if (matched) {
        Track t = tracks_[ui];
        t.count += 1;
        t.last_px = features.keypoints[static_cast<std::size_t>(j)].pt;
        t.last_m = static_cast<float>(d);
        used_[static_cast<std::size_t>(j)] = 1;
        keep(t, track_desc_.ptr(i));
      } else {
        close_track(ui);
      }
    }
  } else {
    for (std::size_t i = 0; i < tracks_.size(); ++i) close_track(i);
  }
  for (int j = 0; j < n_cur; ++j) {
    if (used_[static_cast<std::size_t>(j)]) continue;
    const cv::Point2f p = features.keypoints[static_cast<std::size_t>(j)].pt;
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    keep(Track{1, p, p, static_cast<float>(d), static_cast<float>(d)}, cur.ptr(j));
  }
  std::swap(tracks_, next_tracks_);
  std::swap(track_desc_, next_desc_);
  return ok();
}

Result<SegmentMap> SegmentTeacher::finish(double length_m) {
  if (!std::isfinite(length_m) || length_m < 0.0) return fail("segment length must be finite and >= 0");
  for (std::size_t i = 0; i < tracks_.size(); ++i) close_track(i);
  tracks_.clear();

  // Density cap: per window of kCapWindowM by mid distance, keep the most observed landmarks.
  const std::size_t n = done_.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  auto window = [&](std::size_t i) {
    return static_cast<long>(std::floor((done_[i].first_distance_m + done_[i].last_distance_m) * 0.5 / kCapWindowM));
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const long wa = window(a), wb = window(b);
    if (wa != wb) return wa < wb;
    if (done_[a].count != done_[b].count) return done_[a].count > done_[b].count;
    return a < b;
  });
  const auto per_window = static_cast<std::size_t>(std::max(1.0, std::floor(params_.max_landmarks_per_m * kCapWindowM)));
  std::vector<std::size_t> kept;
  kept.reserve(n);
  for (std::size_t k = 0; k < n;) {
    const long w = window(order[k]);
    std::size_t taken = 0;
    for (; k < n && window(order[k]) == w; ++k) {
      if (taken < per_window) { kept.push_back(order[k]); ++taken; }
    }
  }
  std::sort(kept.begin(), kept.end(), [&](std::size_t a, std::size_t b) {
    if (done_[a].first_distance_m != done_[b].first_distance_m) return done_[a].first_distance_m < done_[b].first_distance_m;
    return a < b;
  });

  SegmentMap m;
  m.length_m = length_m;
  m.azimuth_rad = azimuth_rad_;
  m.landmarks.reserve(kept.size());
  if (!kept.empty()) m.descriptors.create(static_cast<int>(kept.size()), desc_cols_, desc_type_);
  const std::size_t rb = desc_type_ < 0 ? 0 : row_bytes(desc_cols_, desc_type_);
  for (std::size_t r = 0; r < kept.size(); ++r) {
    const std::size_t i = kept[r];
    m.landmarks.push_back(done_[i]);
    std::memcpy(m.descriptors.ptr(static_cast<int>(r)), done_desc_.data() + i * rb, rb);
    m.max_span_m = std::max(m.max_span_m, static_cast<double>(done_[i].last_distance_m) - done_[i].first_distance_m);
  }
  done_.clear();
  done_desc_.clear();
  desc_type_ = -1;
  return m;
}

// ---------------------------------------------------------------- replayer ----

SegmentReplayer::SegmentReplayer(std::shared_ptr<const SegmentMap> map, const SegmentReplayParams& params,
                                 const HeadingParams& heading)
    : map_(std::move(map)), params_(params), estimator_(heading) {
  make_filter();
  if (!map_) {
    map_ = std::make_shared<const SegmentMap>();
    map_valid_ = false;
  } else if (!map_->validate().ok()) {
    map_valid_ = false;  // never index into an inconsistent map; step() reports bad_input
  }
  for (const auto& l : map_->landmarks)
    max_span_m_ = std::max(max_span_m_, static_cast<double>(l.last_distance_m) - l.first_distance_m);
}

void SegmentReplayer::set_params(const SegmentReplayParams& params, const HeadingParams& heading) {
  params_ = params;
  estimator_.set_params(heading);
  make_filter();
}

void SegmentReplayer::make_filter() {
  filter_.reset();
  last_heading_rad_ = std::numeric_limits<double>::quiet_NaN();
  anchor_px_ = std::numeric_limits<double>::quiet_NaN();
  if (!(params_.temporal_decay > 0.0)) return;
  const HeadingParams& h = estimator_.params();
  HeadingFilterParams f;
  f.decay = params_.temporal_decay;
  f.min_votes = h.min_inliers;
  f.full_confidence_votes = std::max<double>(h.full_confidence_inliers, h.min_inliers);
  f.min_confidence = h.min_confidence;
  filter_.emplace(f, h.bin_width_px, h.bin_count);
}

bool SegmentReplayer::apply_filter(HeadingEstimate& est, double d_m, double image_width_px,
                                   double odometry_heading_rad) {
  double shift_px = 0.0;
  if (std::isfinite(odometry_heading_rad) && std::isfinite(last_heading_rad_))
    shift_px = shift_px_for_rotation(std::remainder(odometry_heading_rad - last_heading_rad_, 2.0 * std::numbers::pi),
                                     image_width_px, estimator_.params().horizontal_fov_deg);
  if (std::isfinite(odometry_heading_rad)) last_heading_rad_ = odometry_heading_rad;
  if (std::isfinite(anchor_px_)) anchor_px_ += shift_px;
  auto filtered = filter_->update(estimator_.last_histogram(), shift_px);
  const double bin_px = estimator_.params().bin_width_px;
  const bool usable = filtered && filtered->valid;
  const bool agree = usable && est.valid && std::abs(est.offset_px - filtered->offset_px) <= bin_px;
  const bool on_track = usable && std::isfinite(anchor_px_) && d_m - anchor_d_m_ <= params_.temporal_hold_m &&
                        std::abs(filtered->offset_px - anchor_px_) <= kFilterGateBins * bin_px;
  if (agree) est.confidence = std::max(est.confidence, filtered->confidence);  // keep the refined offset
  if (agree || (est.valid && !on_track)) {
    anchor_px_ = est.offset_px;
    anchor_d_m_ = d_m;
    return false;
  }
  if (!on_track) return false;  // the frame's own (not valid) estimate stands
  est.offset_px = filtered->offset_px;
  const double focal_px = shift_px_for_rotation(1.0, image_width_px, estimator_.params().horizontal_fov_deg);
  est.heading_correction_rad = focal_px > 0.0 ? -std::atan(est.offset_px / focal_px) : 0.0;
  est.confidence = filtered->confidence;
  est.ambiguity = filtered->ambiguity;
  est.valid = true;
  return true;
}

double SegmentReplayer::overshoot_m(double odometry_distance_m) const {
  return std::max(0.0, odometry_distance_m - origin_m_ + correction_m_ - map_->length_m);  // past the corrected end
}

namespace {

// One image axis of a landmark seen while driving straight at it: x - c = A / (X - d), so
// 1 / (x - c) is linear in distance. Returns (position, d position / d distance) at d, or NaN
// when the landmark crosses or touches the principal axis (no usable model) or d is outside [f, g].
std::pair<double, double> hyperbolic_axis(double first, double last, double f, double g, double d, double c) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  constexpr double kMinFromCentrePx = 8.0;
  const double a = first - c, b = last - c;
  if (!(g - f > 1e-6) || d < f || d > g || a * b <= 0.0 || std::abs(a) < kMinFromCentrePx ||
      std::abs(b) < kMinFromCentrePx)
    return {nan, nan};
  const double wa = 1.0 / a, wb = 1.0 / b;
  const double dw = (wb - wa) / (g - f);
  const double w = wa + dw * (d - f);
  return {c + 1.0 / w, -dw / (w * w)};
}

}  // namespace

SegmentReplayer::AlongModel SegmentReplayer::along_model(const Landmark& l, double d, double cx, double cy) {
  AlongModel m;
  if (cx > 0.0) {
    const auto [u, su] = hyperbolic_axis(l.first_px.x, l.last_px.x, l.first_distance_m, l.last_distance_m, d, cx);
    m.u_px = static_cast<float>(u);
    m.slope_u = static_cast<float>(su);
    m.inverse_depth = static_cast<float>(su / (u - cx));  // |u - cx| >= 8 px where finite
  }
  if (cy > 0.0) {
    const auto [v, sv] = hyperbolic_axis(l.first_px.y, l.last_px.y, l.first_distance_m, l.last_distance_m, d, cy);
    m.v_px = static_cast<float>(v);
    m.slope_v = static_cast<float>(sv);
  }
  return m;
}

double SegmentReplayer::estimate_along_m() {
  // du = offset + s_u * delta + q * lateral and dv = pitch + s_v * delta over the matches near
  // the peak: s is the track's slope (px/m), q = s_u / (u - c) = 1 / depth, the regressor of a
  // lateral displacement (parallax: near landmarks shift more; a displaced robot would otherwise
  // read the parallax of a one-sided scene as distance). Each axis centred (intercepts free);
  // delta and lateral shared. Two passes: the second drops residuals > 8 px.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto matches = estimator_.last_matches();
  if (matches.empty()) return nan;
  double offset = 0.0;
  int n_in = 0;
  for (const FeatureMatch& m : matches)
    if (m.inlier) { offset += m.du_px; ++n_in; }
  if (n_in == 0) return nan;
  offset /= n_in;
  along_.clear();
  for (const FeatureMatch& m : matches) {
    if (std::abs(m.du_px - offset) > params_.along_window_px) continue;
    if (m.reference_index < 0 || m.reference_index >= active_count_) continue;
    // Residuals against the landmark's hyperbolic track (the steering uses the chord, which lies
    // inside the curve and would read as a distance error that grows with the slope).
    const AlongModel& a = along_model_[static_cast<std::size_t>(m.reference_index)];
    const cv::Point2f e = expected_[static_cast<std::size_t>(m.reference_index)];
    if (std::isfinite(a.slope_u)) along_.push_back({a.slope_u, a.inverse_depth, m.du_px + (e.x - a.u_px), 0});
    if (std::isfinite(a.slope_v)) along_.push_back({a.slope_v, 0.0f, m.dv_px + (e.y - a.v_px), 1});
  }
  double delta = nan, lateral = 0.0;
  double mean_s[2] = {0, 0}, mean_q[2] = {0, 0}, mean_r[2] = {0, 0};
  constexpr double kMaxResidualPx = 8.0;
  for (int pass = 0; pass < 2; ++pass) {
    double sum_s[2] = {0, 0}, sum_q[2] = {0, 0}, sum_r[2] = {0, 0};
    int n[2] = {0, 0};
    for (const AlongSample& a : along_) {
      sum_s[a.axis] += a.slope;
      sum_q[a.axis] += a.inverse_depth;
      sum_r[a.axis] += a.residual;
      ++n[a.axis];
    }
    if (n[0] + n[1] < 2 * params_.min_along_matches) return nan;
    for (int ax = 0; ax < 2; ++ax) {
      mean_s[ax] = n[ax] > 0 ? sum_s[ax] / n[ax] : 0.0;
      mean_q[ax] = n[ax] > 0 ? sum_q[ax] / n[ax] : 0.0;
      mean_r[ax] = n[ax] > 0 ? sum_r[ax] / n[ax] : 0.0;
    }
    double ss = 0.0, sq = 0.0, qq = 0.0, sr = 0.0, qr = 0.0;
    for (const AlongSample& a : along_) {
      const double ds = a.slope - mean_s[a.axis], dq = a.inverse_depth - mean_q[a.axis],
                   dr = a.residual - mean_r[a.axis];
      ss += ds * ds;
      sq += ds * dq;
      qq += dq * dq;
      sr += ds * dr;
      qr += dq * dr;
    }
    // Information on delta once the lateral term is accounted for (Schur complement).
    const bool with_lateral = qq > 1e-12;
    const double info = with_lateral ? ss - sq * sq / qq : ss;
    if (!(info > 0.0) || !(std::sqrt(info) >= params_.min_along_slope_px_per_m)) return nan;
    if (with_lateral) {
      const double det = ss * qq - sq * sq;
      delta = (sr * qq - qr * sq) / det;
      lateral = (ss * qr - sq * sr) / det;
    } else {
      delta = sr / ss;
      lateral = 0.0;
    }
    if (pass == 1) break;
    std::erase_if(along_, [&](const AlongSample& a) {
      const double predicted = (a.slope - mean_s[a.axis]) * delta + (a.inverse_depth - mean_q[a.axis]) * lateral;
      return std::abs((a.residual - mean_r[a.axis]) - predicted) > kMaxResidualPx;
    });
  }
  return delta;
}

SegmentReplayOutput SegmentReplayer::step(double odometry_distance_m, const Features& current, double image_width_px,
                                          double image_height_px, double odometry_heading_rad) {
  SegmentReplayOutput out;
  if (!map_valid_) {
    out.state = ReplayState::bad_input;  // zero command: an inconsistent map is not replayed
    return out;
  }
  // The steering and the along-track fit look at the odometric distance d (the steering is
  // exactly Algorithm 2's); only the end of the segment moves with the correction. Feeding the
  // corrected distance back into the expected positions coupled the two: a wrong estimate bent
  // the steering near a corner, whose heading error biased the next estimate.
  const double d = odometry_distance_m - origin_m_;
  const double d_end = d + correction_m_;
  out.distance_m = d_end;
  out.along_correction_m = correction_m_;
  active_count_ = 0;
  if (!std::isfinite(d_end) || d_end >= map_->length_m) {
    out.finished = std::isfinite(d_end);
    out.state = out.finished ? ReplayState::finished : ReplayState::bad_input;
    return out;
  }
  out.command.linear_mps = params_.speed_mps;

  // T: landmarks with f - margin <= d <= g + margin; f-sorted, so only [d - span - margin, d + margin].
  const auto& lms = map_->landmarks;
  const double margin = params_.distance_margin_m;
  const double lo_d = d - max_span_m_ - margin, hi_d = d + margin;
  const auto lo = std::lower_bound(lms.begin(), lms.end(), lo_d,
                                   [](const Landmark& l, double v) { return l.first_distance_m < v; });
  const auto hi = std::upper_bound(lo, lms.end(), hi_d,
                                   [](double v, const Landmark& l) { return v < l.first_distance_m; });
  const int window = static_cast<int>(hi - lo);
  if (window > 0) {
    const cv::Mat& all = map_->descriptors;
    if (ref_desc_.rows < window || ref_desc_.cols != all.cols || ref_desc_.type() != all.type())
      ref_desc_.create(std::max(window, std::max(ref_desc_.rows * 2, 256)), all.cols, all.type());
    if (expected_.size() < static_cast<std::size_t>(ref_desc_.rows)) {
      expected_.resize(static_cast<std::size_t>(ref_desc_.rows));
      along_model_.resize(static_cast<std::size_t>(ref_desc_.rows));
    }
    const std::size_t rb = all.cols * all.elemSize();
    for (auto it = lo; it != hi; ++it) {
      if (static_cast<double>(it->last_distance_m) + margin < d) continue;
      const int src = static_cast<int>(it - lms.begin());
      std::memcpy(ref_desc_.ptr(active_count_), all.ptr(src), rb);
      expected_[static_cast<std::size_t>(active_count_)] = it->expected_px(d);
      along_model_[static_cast<std::size_t>(active_count_)] = along_model(*it, d, image_width_px / 2.0, image_height_px / 2.0);
      ++active_count_;
    }
  }
  out.expected_landmarks = active_count_;
  if (active_count_ == 0 || current.keypoints.empty()) {
    out.state = ReplayState::no_features;
    return out;
  }
  const ReferenceView ref{ref_desc_.rowRange(0, active_count_),
                          std::span<const cv::Point2f>(expected_.data(), static_cast<std::size_t>(active_count_))};
  auto est = estimator_.estimate(ref, current, image_width_px);
  if (!est) {
    out.state = ReplayState::bad_input;
    return out;
  }
  out.estimate = *est;
  if (filter_) out.filtered = apply_filter(out.estimate, d, image_width_px, odometry_heading_rad);
  if (!out.estimate.valid) {
    out.state = est->matches == 0 ? ReplayState::no_features : ReplayState::low_confidence;
    return out;
  }
  out.command.angular_radps = std::clamp(-params_.gain_radps_per_px * out.estimate.offset_px,
                                         -params_.max_angular_radps, params_.max_angular_radps);
  out.state = ReplayState::steering;
  if (out.filtered) return out;  // the along-track fit needs this frame's own peak
  out.along_error_m = estimate_along_m();
  // Only a robot that faces the taught view updates it: a heading error moves landmarks at the
  // image borders more than those near the centre, which a one-sided scene reads as distance.
  const bool facing = std::isfinite(out.along_error_m) && std::abs(est->offset_px) <= params_.along_max_offset_px;
  if (params_.along_end_window_m > 0.0) {
    // Only near the end, and only an estimate several frames agree on: a wrong correction is
    // worse than none (the per-frame tracking failed at the campus SW junction that way).
    if (facing && d >= map_->length_m - params_.along_end_window_m) {
      ++window_n_;
      window_sum_m_ += out.along_error_m;
      window_sum_sq_m2_ += out.along_error_m * out.along_error_m;
      const double mean = window_sum_m_ / window_n_;
      const double var = std::max(0.0, window_sum_sq_m2_ / window_n_ - mean * mean);
      if (window_n_ >= params_.along_min_frames && std::sqrt(var) <= params_.along_max_sd_m)
        correction_m_ = std::clamp(mean, -params_.max_along_correction_m, params_.max_along_correction_m);
    }
  } else if (params_.along_gain > 0.0 && facing) {
    const double step = std::clamp(params_.along_gain * (out.along_error_m - correction_m_), -params_.max_along_step_m,
                                   params_.max_along_step_m);
    correction_m_ = std::clamp(correction_m_ + step, -params_.max_along_correction_m, params_.max_along_correction_m);
  }
  return out;
}

}  // namespace visnav::feature_replay
