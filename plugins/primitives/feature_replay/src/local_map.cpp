// Map style B: local-map teacher and replayer (see local_map.hpp; the payload codec is the SDK's,
// runtime/src/map/feature_payloads.cpp).
#include "visnav/feature_replay/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

#include <opencv2/imgcodecs.hpp>

namespace visnav::feature_replay {

// ---------------------------------------------------------------- params ----

const ParamSchema<LocalMapTeachParams>& LocalMapTeachParams::schema() {
  static const auto s =
      ParamSchema<LocalMapTeachParams>{}
          .field("map_interval_m", &LocalMapTeachParams::map_interval_m, "distance between local maps, m (paper: 0.1-0.5)")
          .range(0.01, 100.0)
          .field("max_features_per_map", &LocalMapTeachParams::max_features_per_map,
                 "keep the strongest features of each local map; 0 = all")
          .range(0, 100000)
          .field("store_image", &LocalMapTeachParams::store_image, "store a JPEG of the image in every local map")
          .field("jpeg_quality", &LocalMapTeachParams::jpeg_quality, "JPEG quality of stored images")
          .range(1, 100)
          .field("command_tolerance", &LocalMapTeachParams::command_tolerance,
                 "record a command when v (m/s) or omega (rad/s) changes by more than this")
          .range(0.0, 10.0);
  return s;
}

const ParamSchema<LocalMapReplayParams>& LocalMapReplayParams::schema() {
  static const auto s =
      ParamSchema<LocalMapReplayParams>{}
          .field("gain_radps_per_px", &LocalMapReplayParams::gain_radps_per_px,
                 "heading correction gain: omega += -gain * offset_px, rad/s per px")
          .range(0.0, 1.0)
          .field("max_correction_radps", &LocalMapReplayParams::max_correction_radps, "clamp of |correction|, rad/s")
          .range(0.0, 10.0)
          .field("laps", &LocalMapReplayParams::laps, "traversals of a closed path (distance overshoot carried over)")
          .range(1, 100000)
          .field("min_speed_for_correction_mps", &LocalMapReplayParams::min_speed_for_correction_mps,
                 "no correction while the recorded |v| is below, m/s")
          .range(0.0, 10.0);
  return s;
}

// ---------------------------------------------------------------- teacher ----

LocalMapTeacher::LocalMapTeacher(const LocalMapTeachParams& params) : params_(params) { begin(); }

void LocalMapTeacher::begin() {
  path_ = LocalMapPath{};
  last_distance_m_ = 0.0;
  last_map_m_ = 0.0;
  desc_type_ = -1;
  desc_cols_ = 0;
}

Status LocalMapTeacher::store_map(double distance_m, const Features& features, const cv::Mat& image) {
  VISNAV_TRY(check_features(features, "teach features"));
  const int n_all = static_cast<int>(features.keypoints.size());
  if (n_all > 0) {
    if (desc_type_ < 0) { desc_type_ = features.descriptors.type(); desc_cols_ = features.descriptors.cols; }
    if (features.descriptors.type() != desc_type_ || features.descriptors.cols != desc_cols_)
      return fail("teach features: descriptor type/width changed during the path");
  }
  order_.resize(static_cast<std::size_t>(n_all));
  std::iota(order_.begin(), order_.end(), 0);
  int n = n_all;
  if (params_.max_features_per_map > 0 && n_all > params_.max_features_per_map) {
    n = params_.max_features_per_map;
    std::partial_sort(order_.begin(), order_.begin() + n, order_.end(), [&](int a, int b) {
      return features.keypoints[static_cast<std::size_t>(a)].response > features.keypoints[static_cast<std::size_t>(b)].response;
    });
  }
  LocalMap m;
  m.distance_m = distance_m;
  m.positions_px.reserve(static_cast<std::size_t>(n));
  if (n > 0) m.descriptors.create(n, desc_cols_, desc_type_);
  for (int k = 0; k < n; ++k) {
    const int i = order_[static_cast<std::size_t>(k)];
    m.positions_px.push_back(features.keypoints[static_cast<std::size_t>(i)].pt);
    features.descriptors.row(i).copyTo(m.descriptors.row(k));
  }
  if (params_.store_image && !image.empty()) {
    if (!cv::imencode(".jpg", image, m.jpeg, {cv::IMWRITE_JPEG_QUALITY, params_.jpeg_quality}))
      return fail("could not JPEG-encode the local map image");
  }
  path_.maps.push_back(std::move(m));
  last_map_m_ = distance_m;
  return ok();
}

Status LocalMapTeacher::add_frame(double distance_m, const Features& features, const cv::Mat& image) {
  if (!std::isfinite(distance_m)) return fail("teach distance is not finite");
  const double d = std::max(distance_m, last_distance_m_);
  last_distance_m_ = d;
  if (path_.maps.empty() || d - last_map_m_ >= params_.map_interval_m - 1e-9) return store_map(d, features, image);
  return check_features(features, "teach features");
}

void LocalMapTeacher::record_command(double distance_m, const Twist& command) {
  if (!std::isfinite(distance_m) || !std::isfinite(command.linear_mps) || !std::isfinite(command.angular_radps)) return;
  const double d = std::max(distance_m, last_distance_m_);
  last_distance_m_ = d;
  if (!path_.commands.empty()) {
    const Twist& last = path_.commands.back().command;
    if (std::abs(last.linear_mps - command.linear_mps) <= params_.command_tolerance &&
        std::abs(last.angular_radps - command.angular_radps) <= params_.command_tolerance)
      return;
    if (path_.commands.back().distance_m == d) {  // replaced at the same distance
      path_.commands.back().command = command;
      return;
    }
  }
  path_.commands.push_back(RecordedCommand{d, command});
}

Result<LocalMapPath> LocalMapTeacher::finish(double distance_m, const Features& features, const cv::Mat& image) {
  if (!std::isfinite(distance_m)) return fail("teach distance is not finite");
  const double d = std::max(distance_m, last_distance_m_);
  record_command(d, Twist{});
  if (!features.keypoints.empty() && (path_.maps.empty() || path_.maps.back().distance_m < d))
    VISNAV_TRY(store_map(d, features, image));
  path_.length_m = d;
  LocalMapPath out = std::move(path_);
  begin();
  return out;
}

// ---------------------------------------------------------------- replayer ----

LocalMapReplayer::LocalMapReplayer(std::shared_ptr<const LocalMapPath> path, const LocalMapReplayParams& params,
                                   const HeadingParams& heading)
    : path_(std::move(path)), params_(params), estimator_(heading) {
  if (!path_) {
    path_ = std::make_shared<const LocalMapPath>();
    path_valid_ = false;
  } else if (!path_->validate().ok()) {
    path_valid_ = false;
  }
}

void LocalMapReplayer::set_params(const LocalMapReplayParams& params, const HeadingParams& heading) {
  params_ = params;
  estimator_.set_params(heading);
}

void LocalMapReplayer::begin(double odometry_distance_m) {
  origin_m_ = odometry_distance_m;
  lap_ = 0;
}

double LocalMapReplayer::overshoot_m(double odometry_distance_m) const {
  return std::max(0.0, odometry_distance_m - origin_m_ - path_->length_m);
}

LocalMapReplayOutput LocalMapReplayer::step(double odometry_distance_m, const Features& current, double image_width_px) {
  LocalMapReplayOutput out;
  if (!path_valid_) {
    out.state = ReplayState::bad_input;  // zero command: an inconsistent path is not replayed
    return out;
  }
  const double length = path_->length_m;
  double d = odometry_distance_m - origin_m_;
  if (!std::isfinite(d)) {
    out.state = ReplayState::bad_input;
    out.lap = lap_;
    return out;
  }
  // Closed path: start the next lap at the overshoot instead of at zero.
  while (d >= length && lap_ + 1 < params_.laps && length > 0.0) {
    origin_m_ += length;
    d -= length;
    ++lap_;
    out.lap_completed = true;
  }
  out.lap = lap_;
  out.distance_m = d;
  if (d >= length) {
    out.finished = true;
    out.state = ReplayState::finished;
    return out;
  }
  out.recorded = path_->command_at(d);
  out.command = out.recorded;
  out.map_index = path_->nearest_map(d);
  if (out.map_index < 0 || current.keypoints.empty()) {
    out.state = ReplayState::no_features;
    return out;
  }
  const LocalMap& m = path_->maps[static_cast<std::size_t>(out.map_index)];
  if (m.positions_px.empty()) {
    out.state = ReplayState::no_features;
    return out;
  }
  auto est = estimator_.estimate(m.view(), current, image_width_px);
  if (!est) {
    out.state = ReplayState::bad_input;
    return out;
  }
  out.estimate = *est;
  if (!est->valid) {
    out.state = est->matches == 0 ? ReplayState::no_features : ReplayState::low_confidence;
    return out;
  }
  out.state = ReplayState::steering;
  if (std::abs(out.recorded.linear_mps) < params_.min_speed_for_correction_mps) return out;
  out.correction_radps = std::clamp(-params_.gain_radps_per_px * est->offset_px, -params_.max_correction_radps,
                                    params_.max_correction_radps);
  out.command.angular_radps += out.correction_radps;
  return out;
}

}  // namespace visnav::feature_replay
