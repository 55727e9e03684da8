#include "visnav/visual_memory_payload.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "visnav/map.hpp"

namespace visnav::visual_memory {
namespace {

constexpr std::uint32_t kMagic = 0x314D5656;  // "VVM1" little endian: visual memory, version 1
constexpr std::uint32_t kMaxReferences = 100000;
constexpr std::uint32_t kMaxFeatures = 100000;

bool finite(double v) { return std::isfinite(v); }

}  // namespace

int Reference::count_3d() const {
  return static_cast<int>(std::count(has_3d.begin(), has_3d.end(), std::uint8_t{1}));
}

int Reference::find(std::int32_t id) const {
  auto it = std::find(ids.begin(), ids.end(), id);
  return it == ids.end() ? -1 : static_cast<int>(it - ids.begin());
}

std::vector<std::uint8_t> VisualMemory::encode(int png_compression) const {
  PayloadWriter w;
  w.put<std::uint32_t>(kMagic);
  w.put<std::int32_t>(width_px);
  w.put<std::int32_t>(height_px);
  w.put<double>(focal_px);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(references.size()));
  for (const Reference& r : references) {
    w.put<double>(r.distance_m);
    w.put<double>(r.heading_rad);
    for (int i = 0; i < 9; ++i) w.put<double>(r.R_from_prev.val[i]);
    for (int i = 0; i < 3; ++i) w.put<double>(r.t_from_prev_m[i]);
    std::vector<std::uint8_t> png;
    cv::imencode(".png", r.image, png, {cv::IMWRITE_PNG_COMPRESSION, png_compression});
    w.put_bytes(png);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(r.ids.size()));
    for (std::size_t j = 0; j < r.ids.size(); ++j) {
      w.put<std::int32_t>(r.ids[j]);
      w.put<float>(r.points_px[j].x);
      w.put<float>(r.points_px[j].y);
      w.put<std::uint8_t>(r.has_3d[j]);
      w.put<float>(r.points3d_m[j].x);
      w.put<float>(r.points3d_m[j].y);
      w.put<float>(r.points3d_m[j].z);
    }
  }
  return w.take();
}

Result<VisualMemory> VisualMemory::decode(std::span<const std::uint8_t> body) {
  PayloadReader r(body);
  VisualMemory m;
  VISNAV_ASSIGN(auto magic, r.get<std::uint32_t>());
  if (magic != kMagic) return Error{"not a visual memory (bad magic)", ErrorCode::parse_error};
  VISNAV_ASSIGN(m.width_px, r.get<std::int32_t>());
  VISNAV_ASSIGN(m.height_px, r.get<std::int32_t>());
  VISNAV_ASSIGN(m.focal_px, r.get<double>());
  if (m.width_px < 16 || m.height_px < 16 || m.width_px > 16384 || m.height_px > 16384 || !finite(m.focal_px) ||
      m.focal_px <= 0.0)
    return Error{"implausible image size or focal length", ErrorCode::parse_error};
  VISNAV_ASSIGN(auto count, r.get<std::uint32_t>());
  if (count == 0 || count > kMaxReferences)
    return Error{"implausible reference count " + std::to_string(count), ErrorCode::parse_error};
  m.references.resize(count);
  for (std::uint32_t k = 0; k < count; ++k) {
    Reference& ref = m.references[k];
    const std::string where = "reference " + std::to_string(k) + ": ";
    VISNAV_ASSIGN(ref.distance_m, r.get<double>());
    VISNAV_ASSIGN(ref.heading_rad, r.get<double>());
    for (int i = 0; i < 9; ++i) { VISNAV_ASSIGN(ref.R_from_prev.val[i], r.get<double>()); }
    for (int i = 0; i < 3; ++i) { VISNAV_ASSIGN(ref.t_from_prev_m[i], r.get<double>()); }
    bool ok_numbers = finite(ref.distance_m) && finite(ref.heading_rad);
    for (double v : ref.R_from_prev.val) ok_numbers = ok_numbers && finite(v);
    for (int i = 0; i < 3; ++i) ok_numbers = ok_numbers && finite(ref.t_from_prev_m[i]);
    if (!ok_numbers) return Error{where + "non-finite pose", ErrorCode::parse_error};
    VISNAV_ASSIGN(auto png, r.get_bytes());
    try {
      cv::Mat raw(1, static_cast<int>(png.size()), CV_8UC1, const_cast<std::uint8_t*>(png.data()));
      ref.image = png.empty() ? cv::Mat() : cv::imdecode(raw, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      ref.image.release();
    }
    if (ref.image.empty() || ref.image.cols != m.width_px || ref.image.rows != m.height_px)
      return Error{where + "image does not decode to " + std::to_string(m.width_px) + "x" +
                       std::to_string(m.height_px) + " grey",
                   ErrorCode::parse_error};
    VISNAV_ASSIGN(auto n, r.get<std::uint32_t>());
    if (n > kMaxFeatures || n > r.remaining() / 21)
      return Error{where + "implausible feature count " + std::to_string(n), ErrorCode::parse_error};
    ref.ids.resize(n);
    ref.points_px.resize(n);
    ref.has_3d.resize(n);
    ref.points3d_m.resize(n);
    for (std::uint32_t j = 0; j < n; ++j) {
      VISNAV_ASSIGN(ref.ids[j], r.get<std::int32_t>());
      VISNAV_ASSIGN(ref.points_px[j].x, r.get<float>());
      VISNAV_ASSIGN(ref.points_px[j].y, r.get<float>());
      VISNAV_ASSIGN(ref.has_3d[j], r.get<std::uint8_t>());
      VISNAV_ASSIGN(ref.points3d_m[j].x, r.get<float>());
      VISNAV_ASSIGN(ref.points3d_m[j].y, r.get<float>());
      VISNAV_ASSIGN(ref.points3d_m[j].z, r.get<float>());
      const cv::Point2f& p = ref.points_px[j];
      const cv::Point3f& q = ref.points3d_m[j];
      if (!finite(p.x) || !finite(p.y) || p.x < 0 || p.y < 0 || p.x > m.width_px || p.y > m.height_px ||
          ref.has_3d[j] > 1 || (ref.has_3d[j] == 1 && (!finite(q.x) || !finite(q.y) || !finite(q.z) || q.z <= 0.0f)))
        return Error{where + "feature " + std::to_string(j) + " is out of the image or has a bad 3D point",
                     ErrorCode::parse_error};
    }
  }
  if (!r.at_end()) return Error{"trailing bytes after the visual memory", ErrorCode::parse_error};
  return m;
}

}  // namespace visnav::visual_memory
