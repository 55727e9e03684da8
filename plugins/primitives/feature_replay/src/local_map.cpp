// Map style B: local maps + recorded commands (see local_map.hpp).
#include "visnav/feature_replay/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "binary_io.hpp"

namespace visnav::feature_replay {

namespace {
constexpr char kMagicB[4] = {'V', 'N', 'F', 'B'};
std::size_t row_bytes(int cols, int type) { return static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type); }
}  // namespace

// ---------------------------------------------------------------- LocalMapPath ----

int LocalMapPath::nearest_map(double distance_m) const {
  if (maps.empty()) return -1;
  const auto it = std::lower_bound(maps.begin(), maps.end(), distance_m,
                                   [](const LocalMap& m, double v) { return m.distance_m < v; });
  if (it == maps.begin()) return 0;
  if (it == maps.end()) return static_cast<int>(maps.size()) - 1;
  const auto prev = it - 1;
  return static_cast<int>((distance_m - prev->distance_m <= it->distance_m - distance_m ? prev : it) - maps.begin());
}

Twist LocalMapPath::command_at(double distance_m) const {
  if (commands.empty()) return Twist{};
  const auto it = std::upper_bound(commands.begin(), commands.end(), distance_m,
                                   [](double v, const RecordedCommand& c) { return v < c.distance_m; });
  if (it == commands.begin()) return commands.front().command;
  return (it - 1)->command;
}

Status LocalMapPath::validate() const {
  if (!std::isfinite(length_m) || length_m < 0.0) return fail("path length is not a finite non-negative number");
  double previous = -1e300;
  int type = -1, cols = 0;
  for (std::size_t i = 0; i < maps.size(); ++i) {
    const LocalMap& m = maps[i];
    if (!std::isfinite(m.distance_m) || m.distance_m < previous) return fail("local maps are not sorted by distance");
    previous = m.distance_m;
    if (static_cast<std::size_t>(m.descriptors.rows) != m.positions_px.size())
      return fail("local map " + std::to_string(i) + ": positions and descriptor rows differ");
    if (m.descriptors.empty()) continue;
    if (type < 0) { type = m.descriptors.type(); cols = m.descriptors.cols; }
    if (m.descriptors.type() != type || m.descriptors.cols != cols)
      return fail("local map " + std::to_string(i) + ": descriptor type/width differs from the first map");
    if (type != CV_8UC1 && type != CV_32FC1) return fail("descriptors must be CV_8UC1 or CV_32FC1");
  }
  previous = -1e300;
  for (const auto& c : commands) {
    if (!std::isfinite(c.distance_m) || c.distance_m < previous) return fail("commands are not sorted by distance");
    previous = c.distance_m;
    if (!std::isfinite(c.command.linear_mps) || !std::isfinite(c.command.angular_radps))
      return fail("non-finite recorded command");
  }
  return ok();
}

std::vector<std::uint8_t> LocalMapPath::serialize() const {
  int type = CV_8UC1, cols = 0;
  for (const auto& m : maps) {
    if (!m.descriptors.empty()) { type = m.descriptors.type(); cols = m.descriptors.cols; break; }
  }
  const std::size_t rb = row_bytes(cols, type);
  std::vector<std::uint8_t> out;
  std::size_t estimate = 40 + commands.size() * 12;
  for (const auto& m : maps) estimate += 12 + m.positions_px.size() * (4 + rb) + m.jpeg.size();
  out.reserve(estimate);
  io::Writer w(out);
  w.bytes(kMagicB, 4);
  w.put<std::uint16_t>(kFormatVersion);
  w.put<std::uint8_t>(static_cast<std::uint8_t>(CV_MAT_DEPTH(type) == CV_32F ? io::DescKind::float32 : io::DescKind::binary));
  w.put<std::uint8_t>(0);
  w.put<std::uint16_t>(static_cast<std::uint16_t>(cols));
  w.put<std::uint16_t>(0);
  w.put<double>(length_m);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(maps.size()));
  w.put<std::uint32_t>(static_cast<std::uint32_t>(commands.size()));
  for (const auto& c : commands) {
    w.put<float>(static_cast<float>(c.distance_m));
    w.put<float>(static_cast<float>(c.command.linear_mps));
    w.put<float>(static_cast<float>(c.command.angular_radps));
  }
  for (const auto& m : maps) {
    const std::size_t n = m.descriptors.empty() ? 0 : m.positions_px.size();
    w.put<float>(static_cast<float>(m.distance_m));
    w.put<std::uint32_t>(static_cast<std::uint32_t>(n));
    w.put<std::uint32_t>(static_cast<std::uint32_t>(m.jpeg.size()));
    for (std::size_t i = 0; i < n; ++i) {
      w.put<std::int16_t>(io::to_fixed_px(m.positions_px[i].x));
      w.put<std::int16_t>(io::to_fixed_px(m.positions_px[i].y));
    }
    for (std::size_t i = 0; i < n; ++i) w.bytes(m.descriptors.ptr(static_cast<int>(i)), rb);
    if (!m.jpeg.empty()) w.bytes(m.jpeg.data(), m.jpeg.size());
  }
  return out;
}

Result<LocalMapPath> LocalMapPath::deserialize(std::span<const std::uint8_t> body) {
  io::Reader r(body);
  char magic[4];
  if (!r.bytes(magic, 4) || std::memcmp(magic, kMagicB, 4) != 0)
    return fail("not a feature_replay local-map payload (bad magic)");
  std::uint16_t version = 0, cols = 0, reserved16 = 0;
  std::uint8_t kind = 0, reserved8 = 0;
  std::uint32_t map_count = 0, command_count = 0;
  LocalMapPath p;
  if (!r.get(version)) return fail("local-map payload truncated in the header");
  if (version != kFormatVersion)
    return fail("local-map payload format version " + std::to_string(version) + " is not supported (expected " +
                std::to_string(kFormatVersion) + ")");
  if (!r.get(kind) || !r.get(reserved8) || !r.get(cols) || !r.get(reserved16) || !r.get(p.length_m) ||
      !r.get(map_count) || !r.get(command_count))
    return fail("local-map payload truncated in the header");
  if (kind > 1) return fail("local-map payload: unknown descriptor kind " + std::to_string(kind));
  const int type = kind == 1 ? CV_32FC1 : CV_8UC1;
  const std::size_t rb = row_bytes(cols, type);
  if (static_cast<std::size_t>(command_count) * 12 > r.remaining() ||
      static_cast<std::size_t>(map_count) * 12 > r.remaining() - static_cast<std::size_t>(command_count) * 12)
    return fail("local-map payload truncated: header counts exceed the body");
  p.commands.resize(command_count);
  for (auto& c : p.commands) {
    float d = 0, v = 0, w = 0;
    r.get(d); r.get(v); r.get(w);
    c.distance_m = d;
    c.command.linear_mps = v;
    c.command.angular_radps = w;
  }
  p.maps.resize(map_count);
  for (std::uint32_t k = 0; k < map_count; ++k) {
    LocalMap& m = p.maps[k];
    float d = 0;
    std::uint32_t n = 0, jpeg_bytes = 0;
    if (!r.get(d) || !r.get(n) || !r.get(jpeg_bytes))
      return fail("local-map payload truncated in local map " + std::to_string(k));
    m.distance_m = d;
    if (n > 0 && cols == 0) return fail("local-map payload: features with zero-width descriptors");
    const std::size_t need = static_cast<std::size_t>(n) * (4 + rb) + jpeg_bytes;
    if (need > r.remaining()) return fail("local-map payload truncated in local map " + std::to_string(k));
    m.positions_px.resize(n);
    for (auto& pt : m.positions_px) {
      std::int16_t u = 0, v = 0;
      r.get(u); r.get(v);
      pt = {io::from_fixed_px(u), io::from_fixed_px(v)};
    }
    if (n > 0) {
      m.descriptors.create(static_cast<int>(n), cols, type);
      for (std::uint32_t i = 0; i < n; ++i) r.bytes(m.descriptors.ptr(static_cast<int>(i)), rb);
      if (type == CV_32FC1 && !cv::checkRange(m.descriptors)) return fail("local-map payload: non-finite descriptor value");
    }
    m.jpeg.resize(jpeg_bytes);
    r.bytes(m.jpeg.data(), jpeg_bytes);
  }
  if (r.remaining() != 0) return fail("local-map payload has " + std::to_string(r.remaining()) + " trailing bytes");
  auto valid = p.validate();
  if (!valid) return valid.error().with_context("local-map payload");
  return p;
}

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
