// The feature primitive's payload codecs (see visnav/feature_payloads.hpp): map style A (segment
// landmarks) and map style B (local maps and recorded commands).
#include "visnav/feature_payloads.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

#include <opencv2/core.hpp>

#include "visnav/byte_io.hpp"

namespace visnav::feature_replay {

namespace {
namespace io = visnav::byte_io;
constexpr char kMagicA[4] = {'V', 'N', 'F', 'A'};
constexpr char kMagicB[4] = {'V', 'N', 'F', 'B'};
std::size_t row_bytes(int cols, int type) { return static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type); }
}  // namespace

cv::Point2f Landmark::expected_px(double distance_m) const {
  const double span = static_cast<double>(last_distance_m) - first_distance_m;
  if (!(span > 1e-9)) return first_px;
  const double t = std::clamp((distance_m - first_distance_m) / span, 0.0, 1.0);
  return {static_cast<float>(first_px.x + (last_px.x - first_px.x) * t),
          static_cast<float>(first_px.y + (last_px.y - first_px.y) * t)};
}

// ---------------------------------------------------------------- SegmentMap ----

Status SegmentMap::validate() const {
  if (!std::isfinite(length_m) || length_m < 0.0) return fail("segment length is not a finite non-negative number");
  if (!std::isfinite(azimuth_rad)) return fail("segment azimuth is not finite");
  if (static_cast<std::size_t>(descriptors.rows) != landmarks.size())
    return fail(std::to_string(landmarks.size()) + " landmarks but " + std::to_string(descriptors.rows) + " descriptor rows");
  if (!landmarks.empty() && descriptors.type() != CV_8UC1 && descriptors.type() != CV_32FC1)
    return fail("landmark descriptors must be CV_8UC1 or CV_32FC1");
  float previous = -1e30f;
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const Landmark& l = landmarks[i];
    if (!std::isfinite(l.first_distance_m) || !std::isfinite(l.last_distance_m) || l.last_distance_m < l.first_distance_m)
      return fail("landmark " + std::to_string(i) + ": bad first/last distance");
    if (l.first_distance_m < previous) return fail("landmarks are not sorted by first distance");
    previous = l.first_distance_m;
    if (!std::isfinite(l.first_px.x) || !std::isfinite(l.first_px.y) || !std::isfinite(l.last_px.x) ||
        !std::isfinite(l.last_px.y))
      return fail("landmark " + std::to_string(i) + ": non-finite image position");
  }
  return ok();
}

std::vector<std::uint8_t> SegmentMap::serialize() const {
  std::vector<std::uint8_t> out;
  const bool is_float = descriptors.depth() == CV_32F;
  const int cols = landmarks.empty() ? 0 : descriptors.cols;
  const std::size_t rb = landmarks.empty() ? 0 : row_bytes(cols, descriptors.type());
  out.reserve(32 + landmarks.size() * (rb + 18));
  io::Writer w(out);
  w.bytes(kMagicA, 4);
  w.put<std::uint16_t>(kFormatVersion);
  w.put<std::uint8_t>(static_cast<std::uint8_t>(is_float ? io::DescKind::float32 : io::DescKind::binary));
  w.put<std::uint8_t>(0);
  w.put<std::uint16_t>(static_cast<std::uint16_t>(cols));
  w.put<std::uint16_t>(0);
  w.put<double>(length_m);
  w.put<double>(azimuth_rad);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(landmarks.size()));
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const Landmark& l = landmarks[i];
    w.bytes(descriptors.ptr(static_cast<int>(i)), rb);
    w.put<std::uint16_t>(static_cast<std::uint16_t>(std::min<std::uint32_t>(l.count, 65535)));
    w.put<std::int16_t>(io::to_fixed_px(l.first_px.x));
    w.put<std::int16_t>(io::to_fixed_px(l.first_px.y));
    w.put<std::int16_t>(io::to_fixed_px(l.last_px.x));
    w.put<std::int16_t>(io::to_fixed_px(l.last_px.y));
    w.put<float>(l.first_distance_m);
    w.put<float>(l.last_distance_m);
  }
  return out;
}

Result<SegmentMap> SegmentMap::deserialize(std::span<const std::uint8_t> body) {
  io::Reader r(body);
  char magic[4];
  if (!r.bytes(magic, 4) || std::memcmp(magic, kMagicA, 4) != 0)
    return fail("not a feature_replay segment payload (bad magic)");
  std::uint16_t version = 0, cols = 0, reserved16 = 0;
  std::uint8_t kind = 0, reserved8 = 0;
  SegmentMap m;
  std::uint32_t count = 0;
  if (!r.get(version)) return fail("segment payload truncated in the header");
  if (version != kFormatVersion)
    return fail("segment payload format version " + std::to_string(version) + " is not supported (expected " +
                std::to_string(kFormatVersion) + ")");
  if (!r.get(kind) || !r.get(reserved8) || !r.get(cols) || !r.get(reserved16) || !r.get(m.length_m) ||
      !r.get(m.azimuth_rad) || !r.get(count))
    return fail("segment payload truncated in the header");
  if (kind > 1) return fail("segment payload: unknown descriptor kind " + std::to_string(kind));
  const int type = kind == 1 ? CV_32FC1 : CV_8UC1;
  if (count > 0 && cols == 0) return fail("segment payload: landmarks with zero-width descriptors");
  const std::size_t rb = row_bytes(cols, type);
  const std::size_t record = rb + 2 + 8 + 8;
  if (r.remaining() != static_cast<std::size_t>(count) * record)
    return fail("segment payload size mismatch: " + std::to_string(count) + " landmarks need " +
                std::to_string(static_cast<std::size_t>(count) * record) + " bytes, " + std::to_string(r.remaining()) +
                " present");
  m.landmarks.resize(count);
  if (count > 0) m.descriptors.create(static_cast<int>(count), cols, type);
  for (std::uint32_t i = 0; i < count; ++i) {
    Landmark& l = m.landmarks[i];
    std::uint16_t k = 0;
    std::int16_t u0 = 0, v0 = 0, u1 = 0, v1 = 0;
    r.bytes(m.descriptors.ptr(static_cast<int>(i)), rb);
    r.get(k); r.get(u0); r.get(v0); r.get(u1); r.get(v1);
    r.get(l.first_distance_m); r.get(l.last_distance_m);
    l.count = k;
    l.first_px = {io::from_fixed_px(u0), io::from_fixed_px(v0)};
    l.last_px = {io::from_fixed_px(u1), io::from_fixed_px(v1)};
    m.max_span_m = std::max(m.max_span_m, static_cast<double>(l.last_distance_m) - l.first_distance_m);
  }
  if (kind == 1 && count > 0 && !cv::checkRange(m.descriptors))
    return fail("segment payload: non-finite descriptor value");
  auto valid = m.validate();
  if (!valid) return valid.error().with_context("segment payload");
  return m;
}

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

}  // namespace visnav::feature_replay
