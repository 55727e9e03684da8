// visnav SDK — the payload of `path_following` edges and its codec. It belongs to the
// path-following primitive; it is in the SDK so that other plugins read those edges without
// including a plugin's headers (the place index of relocalisation indexes the thumbnails, issue
// 21). Header-only (like byte_io.hpp): the runtime itself never reads these payloads.
//
// Three versions, all read:
//   VPF1 (magic 0x56504631 "1FPV" little endian): the path's appearance summary only, count n,
//        n x (mean: 3 doubles, covariance: 9 doubles, row-major) in the HSV-cone feature space of
//        the path follower (path_follower.hpp). No thumbnail: such an edge cannot be recognised.
//   VPF2 (magic 0x56504632): the same colour models, then thumbnail width, height (int32 each),
//        count m, m x (distance_m: double, width x height grey bytes, row-major). A thumbnail is the
//        upper kThumbnailRowsShare of the teach frame, grey, area-downsampled to width x height
//        (make_thumbnail), taken every ~0.5 m of odometric edge distance; it is stored as is (not
//        normalised: the reader normalises it for its own comparison).
//   VPF3 (magic 0x56504633, since session 12): VPF2, then the taught path offset profile: count k,
//        k x (distance_m, offset, junction_offset: double each), by non-decreasing distance. The
//        offsets are the path follower's mean normalised offsets of control law (1)
//        (path_follower.hpp: the path's middle relative to the image centre, in [-1, 1], + = right;
//        offset with every path row, junction_offset with the junction-mode rows) of a teach frame
//        in which the path was seen, at that odometric edge distance: where the path lay in the
//        view where the teacher drove, which the replay repeats (docs/path_following.md, "Taught
//        lateral position").
// decode() checks every count, every number's finiteness, the thumbnail size and order; a body
// that does not decode is an error (parse_error), never a crash.
// Ownership: value types; thumbnails are cv::Mat (CV_8UC1, owned, never written after decode).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/map.hpp"
#include "visnav/result.hpp"

namespace visnav::path_payload {

inline constexpr std::uint32_t kMagicV1 = 0x56504631;
inline constexpr std::uint32_t kMagicV2 = 0x56504632;
inline constexpr std::uint32_t kMagicV3 = 0x56504633;
inline constexpr int kThumbnailWidthPx = 64;
inline constexpr int kThumbnailHeightPx = 24;
/// The thumbnail covers the rows above this share of the image height (the far scenery; the
/// bottom quarter is the path surface right in front of the robot, which changes with any
/// lateral offset and looks alike everywhere).
inline constexpr double kThumbnailRowsShare = 0.75;

/// A Gaussian colour model: mean and covariance (row-major) in the HSV-cone feature space.
struct ColourModelData {
  std::array<double, 3> mean{};
  std::array<double, 9> cov{};
};

struct Thumbnail {
  double distance_m = 0.0;  ///< odometric distance along the edge when taken
  cv::Mat image;            ///< CV_8UC1, width_px x height_px
};

/// One teach frame's path offset (VPF3).
struct OffsetSample {
  double distance_m = 0.0;  ///< odometric distance along the edge
  double offset = 0.0;      ///< mean normalised offset of control law (1), [-1, 1], + = path right
  double junction_offset = 0.0;  ///< the same with the junction-mode rows (path_follower.hpp)
};

struct PathPayload {
  std::vector<ColourModelData> models;
  int thumbnail_width_px = kThumbnailWidthPx;
  int thumbnail_height_px = kThumbnailHeightPx;
  std::vector<Thumbnail> thumbnails;  ///< by increasing distance; empty for a VPF1 payload
  std::vector<OffsetSample> offsets;  ///< by non-decreasing distance; empty for VPF1 / VPF2
  std::uint32_t version = 3;          ///< 1, 2 or 3 as decoded; encode() always writes VPF3

  [[nodiscard]] std::vector<std::uint8_t> encode() const;
  static Result<PathPayload> decode(std::span<const std::uint8_t> body);
};

/// The thumbnail of a frame (grey CV_8UC1 or BGR CV_8UC3, at least 8 x 8 px): the upper
/// kThumbnailRowsShare of it, grey, area-downsampled to width x height. Error: empty or
/// unsupported image.
[[nodiscard]] Result<cv::Mat> make_thumbnail(const cv::Mat& image, int width_px = kThumbnailWidthPx,
                                             int height_px = kThumbnailHeightPx);

// ------------------------------------------------------------------------------ implementation

namespace detail {

inline constexpr std::uint32_t kMaxModels = 64;
inline constexpr std::uint32_t kMaxThumbnails = 1000000;
inline constexpr int kMaxThumbnailSide = 512;

inline Error bad(const std::string& what) { return fail(ErrorCode::parse_error, "path-following payload: " + what); }

}  // namespace detail

inline std::vector<std::uint8_t> PathPayload::encode() const {
  PayloadWriter w;
  w.put<std::uint32_t>(kMagicV3);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(models.size()));
  for (const auto& m : models) {
    for (double v : m.mean) w.put<double>(v);
    for (double v : m.cov) w.put<double>(v);
  }
  w.put<std::int32_t>(thumbnail_width_px);
  w.put<std::int32_t>(thumbnail_height_px);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(thumbnails.size()));
  const std::size_t bytes = static_cast<std::size_t>(thumbnail_width_px) * static_cast<std::size_t>(thumbnail_height_px);
  std::vector<std::uint8_t> row(bytes);
  for (const auto& t : thumbnails) {
    w.put<double>(t.distance_m);
    // A thumbnail of another size or type is a bug of the writer (make_thumbnail makes them).
    cv::Mat c = t.image.isContinuous() ? t.image : t.image.clone();
    std::memcpy(row.data(), c.data, std::min(bytes, c.total() * c.elemSize()));
    for (std::uint8_t b : row) w.put<std::uint8_t>(b);
  }
  w.put<std::uint32_t>(static_cast<std::uint32_t>(offsets.size()));
  for (const auto& o : offsets) {
    w.put<double>(o.distance_m);
    w.put<double>(o.offset);
    w.put<double>(o.junction_offset);
  }
  return w.take();
}

inline Result<PathPayload> PathPayload::decode(std::span<const std::uint8_t> body) {
  PayloadReader r(body);
  PathPayload p;
  auto magic = r.get<std::uint32_t>();
  if (!magic) return detail::bad("truncated header");
  if (*magic != kMagicV1 && *magic != kMagicV2 && *magic != kMagicV3)
    return detail::bad("not a path-following payload (bad magic)");
  p.version = *magic == kMagicV1 ? 1 : *magic == kMagicV2 ? 2 : 3;
  auto count = r.get<std::uint32_t>();
  if (!count) return detail::bad("truncated colour model count");
  if (*count > detail::kMaxModels) return detail::bad("implausible number of colour models: " + std::to_string(*count));
  p.models.resize(*count);
  for (auto& m : p.models) {
    for (double& v : m.mean) {
      auto x = r.get<double>();
      if (!x) return detail::bad("truncated colour model");
      v = *x;
    }
    for (double& v : m.cov) {
      auto x = r.get<double>();
      if (!x) return detail::bad("truncated colour model");
      v = *x;
    }
    for (double v : m.mean)
      if (!std::isfinite(v)) return detail::bad("non-finite colour model");
    for (double v : m.cov)
      if (!std::isfinite(v)) return detail::bad("non-finite colour model");
  }
  if (p.version == 1) {
    if (!r.at_end()) return detail::bad("trailing bytes after the colour models");
    p.thumbnails.clear();
    return p;
  }
  auto w = r.get<std::int32_t>();
  auto h = r.get<std::int32_t>();
  auto n = r.get<std::uint32_t>();
  if (!w || !h || !n) return detail::bad("truncated thumbnail header");
  if (*w < 8 || *h < 4 || *w > detail::kMaxThumbnailSide || *h > detail::kMaxThumbnailSide)
    return detail::bad("thumbnail size " + std::to_string(*w) + "x" + std::to_string(*h) + " out of range");
  const std::size_t bytes = static_cast<std::size_t>(*w) * static_cast<std::size_t>(*h);
  const std::size_t thumbnail_bytes = static_cast<std::size_t>(*n) * (8 + bytes);
  if (*n > detail::kMaxThumbnails ||
      (p.version == 2 ? thumbnail_bytes != r.remaining() : thumbnail_bytes + 4 > r.remaining()))
    return detail::bad(std::to_string(*n) + " thumbnails of " + std::to_string(bytes) + " bytes do not fill the " +
               std::to_string(r.remaining()) + " bytes left");
  p.thumbnail_width_px = *w;
  p.thumbnail_height_px = *h;
  p.thumbnails.resize(*n);
  double last = -1e300;
  for (std::size_t i = 0; i < p.thumbnails.size(); ++i) {
    auto d = r.get<double>();
    if (!d || !std::isfinite(*d) || *d < last)
      return detail::bad("thumbnail " + std::to_string(i) + ": distance not finite or not increasing");
    last = *d;
    Thumbnail& t = p.thumbnails[i];
    t.distance_m = *d;
    t.image.create(*h, *w, CV_8UC1);
    for (std::size_t b = 0; b < bytes; ++b) {
      auto v = r.get<std::uint8_t>();
      if (!v) return detail::bad("truncated thumbnail " + std::to_string(i));
      t.image.data[b] = *v;
    }
  }
  if (p.version == 2) return p;
  auto k = r.get<std::uint32_t>();
  if (!k) return detail::bad("truncated offset profile count");
  if (static_cast<std::size_t>(*k) * 24 != r.remaining())
    return detail::bad(std::to_string(*k) + " offset samples do not fill the " + std::to_string(r.remaining()) +
                       " bytes left");
  p.offsets.resize(*k);
  last = -1e300;
  for (std::size_t i = 0; i < p.offsets.size(); ++i) {
    auto d = r.get<double>();
    auto o = r.get<double>();
    auto j = r.get<double>();
    if (!d || !o || !j) return detail::bad("truncated offset sample " + std::to_string(i));
    if (!std::isfinite(*d) || *d < last)
      return detail::bad("offset sample " + std::to_string(i) + ": distance not finite or decreasing");
    if (!std::isfinite(*o) || std::abs(*o) > 1.0 || !std::isfinite(*j) || std::abs(*j) > 1.0)
      return detail::bad("offset sample " + std::to_string(i) + ": offset not finite or outside [-1, 1]");
    last = *d;
    p.offsets[i] = {*d, *o, *j};
  }
  return p;
}

inline Result<cv::Mat> make_thumbnail(const cv::Mat& image, int width_px, int height_px) {
  if (image.empty() || image.rows < 8 || image.cols < 8) return fail(ErrorCode::invalid_value, "thumbnail: image too small");
  if (width_px < 8 || height_px < 4) return fail(ErrorCode::invalid_value, "thumbnail: size too small");
  cv::Mat grey;
  if (image.type() == CV_8UC3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else if (image.type() == CV_8UC1) grey = image;
  else return fail(ErrorCode::invalid_value, "thumbnail: image must be CV_8UC1 or CV_8UC3");
  const int rows = std::max(1, static_cast<int>(std::lround(kThumbnailRowsShare * grey.rows)));
  cv::Mat out;
  cv::resize(grey.rowRange(0, rows), out, cv::Size(width_px, height_px), 0.0, 0.0, cv::INTER_AREA);
  return out;
}

/// The thumbnail comparison relocalisation and the path replay's along-track estimate share:
/// each pixel minus its 5x5 neighbourhood mean over the neighbourhood's standard deviation (plus
/// 2 grey levels, so flat sky does not amplify noise); CV_32FC1 of the thumbnail's size. Local
/// normalisation makes the comparison indifferent to exposure and to slow shading changes.
[[nodiscard]] inline cv::Mat normalise_thumbnail(const cv::Mat& thumbnail_u8) {
  cv::Mat f, mean, mean_sq;
  thumbnail_u8.convertTo(f, CV_32F);
  cv::blur(f, mean, cv::Size(5, 5), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::blur(f.mul(f), mean_sq, cv::Size(5, 5), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::Mat var = mean_sq - mean.mul(mean);
  cv::max(var, 0.0, var);
  cv::Mat sd;
  cv::sqrt(var, sd);
  return (f - mean) / (sd + 2.0f);
}

/// Zero-mean normalised cross-correlation of two normalised thumbnails of one size, the live one
/// shifted by shift_px columns (live column x + shift_px shows what reference column x showed),
/// over their overlap; -1 when the overlap is under half the width, the sizes differ or either is flat.
[[nodiscard]] inline double thumbnail_ncc(const cv::Mat& live, const cv::Mat& reference, int shift_px) {
  const int w = live.cols;
  const int overlap = w - std::abs(shift_px);
  if (2 * overlap < w || reference.size() != live.size() || live.type() != CV_32FC1 || reference.type() != CV_32FC1)
    return -1.0;
  const int ref0 = shift_px >= 0 ? 0 : -shift_px;
  const int live0 = shift_px >= 0 ? shift_px : 0;
  double sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
  for (int y = 0; y < live.rows; ++y) {
    const float* a = live.ptr<float>(y) + live0;
    const float* b = reference.ptr<float>(y) + ref0;
    float ra = 0.f, rb = 0.f, raa = 0.f, rbb = 0.f, rab = 0.f;  // a row in float, the sum in double
    for (int x = 0; x < overlap; ++x) {
      ra += a[x];
      rb += b[x];
      raa += a[x] * a[x];
      rbb += b[x] * b[x];
      rab += a[x] * b[x];
    }
    sa += ra;
    sb += rb;
    saa += raa;
    sbb += rbb;
    sab += rab;
  }
  const double n = static_cast<double>(overlap) * live.rows;
  const double va = saa - sa * sa / n;
  const double vb = sbb - sb * sb / n;
  if (va <= 1e-9 || vb <= 1e-9) return -1.0;  // a flat thumbnail correlates with nothing
  return (sab - sa * sb / n) / std::sqrt(va * vb);
}

}  // namespace visnav::path_payload
