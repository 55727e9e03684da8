// Pinhole renderer: row-wise ground ray casting + convex-polygon wall rasterisation.
#include "visnav_sim/render.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace visnav::sim {
namespace {

constexpr double kTexOffset = 16777216.0;  // 2^24: keeps texel coordinates positive before masking
constexpr double kNearM = 0.02;
constexpr int kMaxPolygon = 72;  // an obstacle top of 64 sides (the schema's limit) after near-plane clipping

// A convex polygon clipped against the near plane and projected: pixel vertices and bounds.
struct ScreenPolygon {
  cv::Point2d img[kMaxPolygon];
  int n = 0;
  double vmin = 1e300, vmax = -1e300, umin = 1e300, umax = -1e300;
};

// Clips the convex polygon `cam` (camera coordinates, `count` vertices, count + 8 <= kMaxPolygon)
// against the near plane (Sutherland–Hodgman, one plane) and projects it. False when nothing of
// it lies in front of the camera or inside the W x H image.
bool clip_and_project(const cv::Vec3d* cam, int count, double f, double cx, double cy, int W, int H, ScreenPolygon& out) {
  cv::Vec3d clipped[kMaxPolygon];
  int n = 0;
  for (int k = 0; k < count; ++k) {
    const cv::Vec3d& a = cam[k];
    const cv::Vec3d& b = cam[(k + 1) % count];
    const bool ain = a[2] > kNearM, bin = b[2] > kNearM;
    if (ain) clipped[n++] = a;
    if (ain != bin) {
      const double s = (kNearM - a[2]) / (b[2] - a[2]);
      clipped[n++] = a + (b - a) * s;
    }
  }
  if (n < 3) return false;
  out.n = n;
  out.vmin = out.umin = 1e300;
  out.vmax = out.umax = -1e300;
  for (int k = 0; k < n; ++k) {
    out.img[k] = cv::Point2d(f * clipped[k][0] / clipped[k][2] + cx, f * clipped[k][1] / clipped[k][2] + cy);
    out.vmin = std::min(out.vmin, out.img[k].y); out.vmax = std::max(out.vmax, out.img[k].y);
    out.umin = std::min(out.umin, out.img[k].x); out.umax = std::max(out.umax, out.img[k].x);
  }
  return !(out.vmax < 0 || out.vmin > H - 1 || out.umax < 0 || out.umin > W - 1);
}

// Pixel columns [u0, u1] of row v inside the polygon; false when the row misses it.
bool row_span(const ScreenPolygon& p, int v, int W, int& u0, int& u1) {
  double xl = 1e300, xr = -1e300;
  for (int k = 0; k < p.n; ++k) {
    const cv::Point2d& a = p.img[k];
    const cv::Point2d& b = p.img[(k + 1) % p.n];
    if ((a.y <= v && b.y > v) || (b.y <= v && a.y > v)) {
      const double x = a.x + (v - a.y) * (b.x - a.x) / (b.y - a.y);
      xl = std::min(xl, x); xr = std::max(xr, x);
    } else if (a.y == v && b.y == v) {
      xl = std::min({xl, a.x, b.x}); xr = std::max({xr, a.x, b.x});
    }
  }
  if (xl > xr) return false;
  u0 = std::max(0, static_cast<int>(std::ceil(xl)));
  u1 = std::min(W - 1, static_cast<int>(std::ceil(xr)) - 1);
  return u0 <= u1;
}

// A texel faded towards the horizon colour by `fog` (0-256; 0 = none).
cv::Vec3b fogged(std::uint32_t texel, int fog, const cv::Vec3b& horizon) {
  int b = static_cast<int>(texel & 0xFF), g = static_cast<int>((texel >> 8) & 0xFF), r = static_cast<int>((texel >> 16) & 0xFF);
  if (fog > 0) {
    b = (b * (256 - fog) + horizon[0] * fog) >> 8;
    g = (g * (256 - fog) + horizon[1] * fog) >> 8;
    r = (r * (256 - fog) + horizon[2] * fog) >> 8;
  }
  return {static_cast<unsigned char>(b), static_cast<unsigned char>(g), static_cast<unsigned char>(r)};
}

inline int floor_log2(float x) {  // x > 0
  const auto bits = std::bit_cast<std::uint32_t>(x);
  return static_cast<int>((bits >> 23) & 0xFF) - 127;
}

/// One texture at one mip level, ready for nearest-texel lookup.
struct TexLevel {
  const std::uint32_t* data = nullptr;  // BGRA packed little-endian
  int log2 = 0;
  int mask = 0;
  double scale = 1.0;  // texels per metre
};

inline TexLevel tex_level(const Texture& t, int level) {
  level = std::clamp(level, 0, static_cast<int>(t.levels.size()) - 1);
  TexLevel l;
  l.data = reinterpret_cast<const std::uint32_t*>(t.levels[static_cast<size_t>(level)].data);
  l.log2 = t.size_log2 - level;
  l.mask = (1 << l.log2) - 1;
  l.scale = 1.0 / (t.texel_m * static_cast<double>(1 << level));
  return l;
}

inline cv::Vec3d col(const cv::Matx33d& m, int c) { return {m(0, c), m(1, c), m(2, c)}; }

}  // namespace

double CameraModel::fx() const { return (width_px * 0.5) / std::tan(hfov_deg * CV_PI / 360.0); }

Status CameraModel::validate() const {
  if (width_px < 8 || height_px < 8 || width_px > 8192 || height_px > 8192)
    return fail("image size " + std::to_string(width_px) + "x" + std::to_string(height_px) + " is out of range [8, 8192]");
  if (!(hfov_deg > 1.0 && hfov_deg < 170.0)) return fail("hfov_deg " + std::to_string(hfov_deg) + " is out of range (1, 170)");
  if (!(height_m > 0.01)) return fail("camera height " + std::to_string(height_m) + " m must be > 0.01 m");
  if (!(std::abs(pitch_down_deg) < 80.0)) return fail("pitch_down_deg must be in (-80, 80)");
  if (!(max_range_m > 1.0 && max_range_m <= 1000.0)) return fail("max_range_m must be in (1, 1000]");
  return ok();
}

CameraPose camera_pose(const CameraModel& model, const Pose2D& p) {
  const double c = std::cos(p.heading_rad), s = std::sin(p.heading_rad);
  const cv::Vec3d f(c, s, 0), l(-s, c, 0), up(0, 0, 1);
  const double phi = model.pitch_down_deg * CV_PI / 180.0;
  const cv::Vec3d zc = std::cos(phi) * f - std::sin(phi) * up;
  const cv::Vec3d xc = -l;
  const cv::Vec3d yc = -std::cos(phi) * up - std::sin(phi) * f;
  CameraPose pose;
  pose.R_world_cam = cv::Matx33d(xc[0], yc[0], zc[0], xc[1], yc[1], zc[1], xc[2], yc[2], zc[2]);
  pose.position_world = cv::Vec3d(p.x_m, p.y_m, 0) + model.forward_m * f + model.lateral_m * l + model.height_m * up;
  return pose;
}

std::optional<cv::Point2d> project(const CameraModel& model, const CameraPose& pose, const cv::Vec3d& point_world) {
  const cv::Vec3d pc = pose.R_world_cam.t() * (point_world - pose.position_world);
  if (pc[2] <= 1e-3) return std::nullopt;
  const double f = model.fx();
  return cv::Point2d(f * pc[0] / pc[2] + model.cx(), f * pc[1] / pc[2] + model.cy());
}

Renderer::Renderer(std::shared_ptr<const World> world, CameraModel model, RenderOptions options)
    : world_(std::move(world)), model_(model), options_(std::move(options)) {
  CV_Assert(world_ != nullptr && model_.validate().ok());
  const World& w = *world_;
  texture_for_id_.resize(w.textures.size());
  for (size_t i = 0; i < w.textures.size(); ++i) {
    texture_for_id_[i] = &w.textures[i];
    if (!options_.season.empty())
      for (const auto& [season, idx] : w.textures[i].seasons)
        if (season == options_.season) texture_for_id_[i] = &w.textures[static_cast<size_t>(idx)];
  }
  region_texture_.push_back(texture_for_id_[static_cast<size_t>(w.default_texture)]);
  region_label_.push_back(static_cast<std::uint8_t>(w.default_label));
  for (const auto& r : w.regions) {
    region_texture_.push_back(texture_for_id_[static_cast<size_t>(r.texture)]);
    region_label_.push_back(static_cast<std::uint8_t>(r.label));
  }
  inv_depth_.assign(static_cast<size_t>(model_.width_px) * model_.height_px, 0.0f);
  shadow_lut_.assign(256, 255);
  const ShadowBands& sb = options_.shadows;
  if (sb.strength > 0.0) {
    for (int i = 0; i < 256; ++i) {
      const double pos = (i + 0.5) / 256.0 * sb.period_m;  // metres into the period
      // soft-edged band of width_m centred at width_m/2
      const double edge = 0.08 * sb.period_m;
      const double inside = std::clamp(std::min(pos, sb.width_m - pos) / edge + 0.5, 0.0, 1.0);
      shadow_lut_[static_cast<size_t>(i)] = static_cast<std::uint8_t>(std::lround(255.0 * (1.0 - sb.strength * inside)));
    }
  }
  fog_lut_.assign(4096, 0);
  if (w.fog_distance_m > 0)
    for (size_t i = 0; i < fog_lut_.size(); ++i)
      fog_lut_[i] = static_cast<std::uint16_t>(std::lround(256.0 * (1.0 - std::exp(-(static_cast<double>(i) * 0.25) / w.fog_distance_m))));
}

void Renderer::render(const Pose2D& robot_pose_world, cv::Mat& bgr, cv::Mat* labels, cv::Mat* object_ids, double time_s) {
  bgr.create(model_.height_px, model_.width_px, CV_8UC3);
  if (labels != nullptr) labels->create(model_.height_px, model_.width_px, CV_8UC1);
  if (object_ids != nullptr) object_ids->create(model_.height_px, model_.width_px, CV_16UC1);
  const CameraPose pose = camera_pose(model_, robot_pose_world);
  const bool with_labels = labels != nullptr || object_ids != nullptr;
  const bool shadows = options_.shadows.strength > 0.0;
  if (with_labels) {
    if (shadows) render_ground<true, true>(pose, bgr, labels, object_ids);
    else render_ground<true, false>(pose, bgr, labels, object_ids);
    render_walls<true>(pose, bgr, labels, object_ids, time_s);
    render_caps<true>(pose, bgr, labels, object_ids, time_s);
  } else {
    if (shadows) render_ground<false, true>(pose, bgr, labels, object_ids);
    else render_ground<false, false>(pose, bgr, labels, object_ids);
    render_walls<false>(pose, bgr, labels, object_ids, time_s);
    render_caps<false>(pose, bgr, labels, object_ids, time_s);
  }
}

template <bool kLabels, bool kShadows>
void Renderer::render_ground(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids) {
  const World& w = *world_;
  const int W = model_.width_px, H = model_.height_px;
  const double f = model_.fx(), cx = model_.cx(), cy = model_.cy();
  const cv::Vec3d xc = col(pose.R_world_cam, 0), yc = col(pose.R_world_cam, 1), zc = col(pose.R_world_cam, 2);
  const cv::Vec3d C = pose.position_world;
  const cv::Vec3b hz = w.sky_horizon_bgr, zen = w.sky_zenith_bgr;

  const std::uint16_t* map = w.region_map.ptr<std::uint16_t>();
  const int mw = w.region_map.cols, mh = w.region_map.rows;
  const double ox = w.region_map_origin_m.x, oy = w.region_map_origin_m.y;
  const double inv_res = 1.0 / w.region_map_resolution_m;

  const size_t n_regions = region_texture_.size();
  thread_local std::vector<TexLevel> row_tex;
  row_tex.resize(n_regions);
  const double sdir = options_.shadows.direction_deg * CV_PI / 180.0;
  const double shadow_scale = 256.0 / std::max(options_.shadows.period_m, 1e-3);
  const double shx = std::cos(sdir) * shadow_scale, shy = std::sin(sdir) * shadow_scale;
  const Texture* far_tex = region_texture_[0];
  const std::uint32_t far_texel = reinterpret_cast<const std::uint32_t*>(far_tex->levels.back().data)[0];

  auto dir_z = [&](double v) { return yc[2] * (v - cy) / f + zc[2]; };

  for (int v = 0; v < H; ++v) {
    auto* out = bgr.ptr<cv::Vec3b>(v);
    std::uint8_t* lab = kLabels && labels != nullptr ? labels->ptr<std::uint8_t>(v) : nullptr;
    std::uint16_t* oid = kLabels && ids != nullptr ? ids->ptr<std::uint16_t>(v) : nullptr;
    const cv::Vec3d A = yc * ((v - cy) / f) + zc - xc * (cx / f);
    const cv::Vec3d B = xc * (1.0 / f);
    const double dz = A[2];
    const cv::Vec3d dcen = A + B * cx;
    const double horiz = std::hypot(dcen[0], dcen[1]);
    const double t = dz < -1e-9 ? -C[2] / dz : 0.0;
    const double range = t * std::sqrt(horiz * horiz + dz * dz);
    if (dz >= -1e-9 || range > model_.max_range_m) {
      // sky (or ground beyond max range, drawn as the far horizon)
      cv::Vec3b color;
      std::uint8_t label = static_cast<std::uint8_t>(LabelClass::sky);
      std::uint16_t id = 0;
      if (dz >= -1e-9) {
        const double elev = std::atan2(dz, horiz);
        const double k = std::pow(std::clamp(elev / (CV_PI / 3.0), 0.0, 1.0), 0.7);
        for (int c = 0; c < 3; ++c) color[c] = static_cast<unsigned char>(std::lround(hz[c] * (1 - k) + zen[c] * k));
      } else {
        const auto* fp = reinterpret_cast<const unsigned char*>(&far_texel);
        const double k = w.fog_distance_m > 0 ? 1.0 : 0.0;
        for (int c = 0; c < 3; ++c) color[c] = static_cast<unsigned char>(std::lround(fp[c] * (1 - k) + hz[c] * k));
        label = static_cast<std::uint8_t>(w.default_label);
        id = 0x7FFF;
      }
      for (int u = 0; u < W; ++u) out[u] = color;
      if constexpr (kLabels) {
        if (lab != nullptr) std::memset(lab, label, static_cast<size_t>(W));
        if (oid != nullptr) std::fill(oid, oid + W, id);
      }
      continue;
    }
    // footprint of one pixel on the ground: across (t/f) and along (distance to the next row)
    const double foot_u = t / f;
    const double dz_next = dir_z(v + 1.0);
    double foot_v = 1e9;
    if (dz_next < -1e-9) {
      const double t2 = -C[2] / dz_next;
      const cv::Vec3d d2 = A + yc * (1.0 / f) + B * cx;
      foot_v = std::hypot(C[0] + t2 * d2[0] - (C[0] + t * dcen[0]), C[1] + t2 * d2[1] - (C[1] + t * dcen[1]));
    }
    const double foot = std::sqrt(foot_u * std::max(foot_u, std::min(foot_v, foot_u * 16.0)));
    for (size_t r = 0; r < n_regions; ++r) {
      const Texture& tex = *region_texture_[r];
      const int level = std::max(0, static_cast<int>(std::floor(std::log2(foot / tex.texel_m))));
      row_tex[r] = tex_level(tex, level);
    }
    const std::uint16_t fog = w.fog_distance_m > 0 ? fog_lut_[std::min<size_t>(fog_lut_.size() - 1, static_cast<size_t>(range * 4.0))] : 0;
    const int fog_keep = 256 - fog;
    const int fog_b = hz[0] * fog, fog_g = hz[1] * fog, fog_r = hz[2] * fog;

    double X = C[0] + t * A[0], Y = C[1] + t * A[1];
    const double dX = t * B[0], dY = t * B[1];
    double gx = (X - ox) * inv_res, gy = (Y - oy) * inv_res;
    const double dgx = dX * inv_res, dgy = dY * inv_res;
    double sh = X * shx + Y * shy;
    const double dsh = dX * shx + dY * shy;
    for (int u = 0; u < W; ++u, X += dX, Y += dY, gx += dgx, gy += dgy, sh += dsh) {
      int region = 0;
      if (gx >= 0.0 && gy >= 0.0 && gx < mw && gy < mh)
        region = map[static_cast<size_t>(static_cast<int>(gy)) * mw + static_cast<int>(gx)];
      const TexLevel& tl = row_tex[static_cast<size_t>(region)];
      const int tx = static_cast<int>(X * tl.scale + kTexOffset) & tl.mask;
      const int ty = static_cast<int>(kTexOffset - Y * tl.scale) & tl.mask;
      const std::uint32_t texel = tl.data[(ty << tl.log2) | tx];
      int b = static_cast<int>(texel & 0xFF), g = static_cast<int>((texel >> 8) & 0xFF), r = static_cast<int>((texel >> 16) & 0xFF);
      if constexpr (kShadows) {
        const int k = shadow_lut_[static_cast<size_t>(static_cast<std::int64_t>(sh + kTexOffset) & 255)];
        b = (b * k) >> 8; g = (g * k) >> 8; r = (r * k) >> 8;
      }
      out[u] = cv::Vec3b(static_cast<unsigned char>((b * fog_keep + fog_b) >> 8),
                         static_cast<unsigned char>((g * fog_keep + fog_g) >> 8),
                         static_cast<unsigned char>((r * fog_keep + fog_r) >> 8));
      if constexpr (kLabels) {
        if (lab != nullptr) lab[u] = region_label_[static_cast<size_t>(region)];
        if (oid != nullptr) oid[u] = region == 0 ? std::uint16_t{0x7FFF} : region;
      }
    }
  }
}

template <bool kLabels>
void Renderer::render_walls(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids, double time_s) {
  const World& w = *world_;
  if (w.walls.empty()) return;
  const int W = model_.width_px, H = model_.height_px;
  const double f = model_.fx(), cx = model_.cx(), cy = model_.cy();
  const cv::Matx33d Rt = pose.R_world_cam.t();
  const cv::Vec3d C = pose.position_world;
  std::fill(inv_depth_.begin(), inv_depth_.end(), 0.0f);
  const cv::Vec3b hz = w.sky_horizon_bgr;
  const bool fog_on = w.fog_distance_m > 0;

  for (size_t wi = 0; wi < w.walls.size(); ++wi) {
    const Wall& wall = w.walls[wi];
    const cv::Point2d shift = wall.mover >= 0 && mover_offsets_ ? mover_offsets_(wall.mover, time_s)
                                                                 : w.wall_offset(wall, time_s);  // moving obstacles
    const cv::Point2d from = wall.from + shift, to = wall.to + shift;
    const cv::Vec3d p0(from.x, from.y, 0.0);
    const cv::Vec3d along(to.x - from.x, to.y - from.y, 0.0);
    const double len = cv::norm(along);
    const cv::Vec3d e = along / len;
    // cheap reject: wall entirely behind the camera
    const cv::Vec3d corners_w[4] = {{from.x, from.y, wall.base_m}, {to.x, to.y, wall.base_m},
                                    {to.x, to.y, wall.top_m}, {from.x, from.y, wall.top_m}};
    cv::Vec3d cam[4];
    bool any_front = false;
    for (int k = 0; k < 4; ++k) {
      cam[k] = Rt * (corners_w[k] - C);
      any_front = any_front || cam[k][2] > kNearM;
    }
    if (!any_front) continue;
    ScreenPolygon poly;
    if (!clip_and_project(cam, 4, f, cx, cy, W, H, poly)) continue;
    // plane in camera coordinates
    const cv::Vec3d ec = Rt * e, zc = Rt * cv::Vec3d(0, 0, 1), Ac = Rt * (p0 - C);
    const cv::Vec3d nc = ec.cross(zc);
    const double dist = nc.dot(Ac);
    if (std::abs(dist) < 1e-6) continue;  // seen edge-on
    const double eA = ec.dot(Ac), zA = zc.dot(Ac);
    const Texture& tex = *texture_for_id_[static_cast<size_t>(wall.texture)];
    const int side = 1 << tex.size_log2;
    const double tile_scale = 1.0 / tex.texel_m;
    const double stretch_su = side / len, stretch_sv = side / (wall.top_m - wall.base_m);
    const double texel_s = tex.tiled ? tex.texel_m : len / side;
    const double texel_h = tex.tiled ? tex.texel_m : (wall.top_m - wall.base_m) / side;
    const float inv_texel = static_cast<float>(1.0 / std::sqrt(texel_s * texel_h));
    const std::uint8_t label = static_cast<std::uint8_t>(wall.label);
    const std::uint16_t oid_value = static_cast<std::uint16_t>(0x8000 + wi);
    const int max_level = static_cast<int>(tex.levels.size()) - 1;

    const int v0 = std::max(0, static_cast<int>(std::ceil(poly.vmin))), v1 = std::min(H - 1, static_cast<int>(std::floor(poly.vmax)));
    for (int v = v0; v <= v1; ++v) {
      int u0 = 0, u1 = -1;
      if (!row_span(poly, v, W, u0, u1)) continue;
      const double yv = (v - cy) / f;
      // affine-in-u quantities: inverse depth, e·d, z·d
      const double iz0 = (nc[1] * yv + nc[2] - nc[0] * cx / f) / dist, iz1 = nc[0] / f / dist;
      const double es0 = ec[1] * yv + ec[2] - ec[0] * cx / f, es1 = ec[0] / f;
      const double hs0 = zc[1] * yv + zc[2] - zc[0] * cx / f, hs1 = zc[0] / f;
      auto* out = bgr.ptr<cv::Vec3b>(v);
      float* zb = inv_depth_.data() + static_cast<size_t>(v) * W;
      std::uint8_t* lab = kLabels && labels != nullptr ? labels->ptr<std::uint8_t>(v) : nullptr;
      std::uint16_t* oid = kLabels && ids != nullptr ? ids->ptr<std::uint16_t>(v) : nullptr;
      for (int u = u0; u <= u1; ++u) {
        const double iz = iz0 + iz1 * u;
        if (iz <= 0.0 || static_cast<float>(iz) <= zb[u]) continue;
        const double z = 1.0 / iz;
        const double es = es0 + es1 * u, hs = hs0 + hs1 * u;
        const double s = es * z - eA, h = hs * z - zA;
        // footprint: geometric mean of the along-wall derivative and the frontal size z/f
        const double ds = std::abs((es1 * iz - es * iz1) * z * z);
        const float foot = static_cast<float>(std::sqrt(std::max(ds, 1e-9) * (z / f))) * inv_texel;
        const int level = foot < 1.0f ? 0 : std::min(max_level, floor_log2(foot));
        const int lside_log2 = tex.size_log2 - level;
        const int lmask = (1 << lside_log2) - 1;
        const auto* data = reinterpret_cast<const std::uint32_t*>(tex.levels[static_cast<size_t>(level)].data);
        int tx, ty;
        if (tex.tiled) {
          const double sc = tile_scale / static_cast<double>(1 << level);
          tx = static_cast<int>(s * sc + kTexOffset) & lmask;
          ty = static_cast<int>(kTexOffset - h * sc) & lmask;
        } else {
          tx = std::clamp(static_cast<int>(s * stretch_su) >> level, 0, lmask);
          ty = std::clamp(static_cast<int>((wall.top_m - h) * stretch_sv) >> level, 0, lmask);
        }
        const std::uint32_t texel = data[(ty << lside_log2) | tx];
        if (tex.has_alpha && (texel >> 24) < 128) continue;
        zb[u] = static_cast<float>(iz);
        out[u] = fogged(texel, fog_on ? fog_lut_[std::min<size_t>(fog_lut_.size() - 1, static_cast<size_t>(z * 4.0))] : 0, hz);
        if constexpr (kLabels) {
          if (lab != nullptr) lab[u] = label;
          if (oid != nullptr) oid[u] = oid_value;
        }
      }
    }
  }
}

// Obstacle tops: horizontal convex polygons, drawn after the walls into the same inverse-depth
// buffer (render_walls clears it). Seen only from above: a top at or above the camera faces away.
template <bool kLabels>
void Renderer::render_caps(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids, double time_s) {
  const World& w = *world_;
  if (w.caps.empty()) return;
  const int W = model_.width_px, H = model_.height_px;
  const double f = model_.fx(), cx = model_.cx(), cy = model_.cy();
  const cv::Matx33d Rt = pose.R_world_cam.t();
  const cv::Vec3d C = pose.position_world;
  const cv::Vec3d xw = col(pose.R_world_cam, 0), yw = col(pose.R_world_cam, 1), zw = col(pose.R_world_cam, 2);
  const cv::Vec3d nc = Rt * cv::Vec3d(0, 0, 1);  // the tops' normal in camera coordinates
  const cv::Vec3b hz = w.sky_horizon_bgr;
  const bool fog_on = w.fog_distance_m > 0;

  for (const Cap& cap : w.caps) {
    const double dist = cap.top_m - C[2];  // signed distance of the top's plane along world up
    if (dist > -1e-6) continue;             // at or above the camera: its underside faces the camera
    const std::size_t nv = cap.ring.size();
    if (nv < 3 || nv + 8 > static_cast<std::size_t>(kMaxPolygon)) continue;
    const cv::Point2d shift = cap.mover >= 0 && mover_offsets_ ? mover_offsets_(cap.mover, time_s)
                                                                : (cap.mover >= 0 ? w.movers[static_cast<std::size_t>(cap.mover)].offset_at(time_s)
                                                                                  : cv::Point2d(0, 0));
    cv::Vec3d cam[kMaxPolygon];
    bool any_front = false;
    double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
    for (std::size_t k = 0; k < nv; ++k) {
      const cv::Point2d q = cap.ring[k] + shift;
      min_x = std::min(min_x, q.x); max_x = std::max(max_x, q.x);
      min_y = std::min(min_y, q.y); max_y = std::max(max_y, q.y);
      cam[k] = Rt * (cv::Vec3d(q.x, q.y, cap.top_m) - C);
      any_front = any_front || cam[k][2] > kNearM;
    }
    if (!any_front) continue;
    ScreenPolygon poly;
    if (!clip_and_project(cam, static_cast<int>(nv), f, cx, cy, W, H, poly)) continue;
    const Texture& tex = *texture_for_id_[static_cast<size_t>(cap.texture)];
    const int side = 1 << tex.size_log2;
    const double tile_scale = 1.0 / tex.texel_m;
    // A stretched (untiled) texture covers the top's bounding box once.
    const double stretch_x = side / std::max(max_x - min_x, 1e-6), stretch_y = side / std::max(max_y - min_y, 1e-6);
    const double texel_m = tex.tiled ? tex.texel_m : std::sqrt((max_x - min_x) * (max_y - min_y)) / side;
    const std::uint8_t label = static_cast<std::uint8_t>(cap.label);
    const std::uint16_t oid_value = static_cast<std::uint16_t>(0x8000 + cap.first_wall);
    const int max_level = static_cast<int>(tex.levels.size()) - 1;
    const double height_above_m = -dist;

    const int v0 = std::max(0, static_cast<int>(std::ceil(poly.vmin))), v1 = std::min(H - 1, static_cast<int>(std::floor(poly.vmax)));
    for (int v = v0; v <= v1; ++v) {
      int u0 = 0, u1 = -1;
      if (!row_span(poly, v, W, u0, u1)) continue;
      const double yv = (v - cy) / f;
      // inverse depth and the world ray are affine in u along a row
      const double iz0 = (nc[1] * yv + nc[2] - nc[0] * cx / f) / dist, iz1 = nc[0] / f / dist;
      const cv::Vec3d ray0 = yw * yv + zw - xw * (cx / f), ray1 = xw * (1.0 / f);
      auto* out = bgr.ptr<cv::Vec3b>(v);
      float* zb = inv_depth_.data() + static_cast<size_t>(v) * W;
      std::uint8_t* lab = kLabels && labels != nullptr ? labels->ptr<std::uint8_t>(v) : nullptr;
      std::uint16_t* oid = kLabels && ids != nullptr ? ids->ptr<std::uint16_t>(v) : nullptr;
      for (int u = u0; u <= u1; ++u) {
        const double iz = iz0 + iz1 * u;
        if (iz <= 0.0 || static_cast<float>(iz) <= zb[u]) continue;
        const double z = 1.0 / iz;
        const cv::Vec3d ray = ray0 + ray1 * u;
        const double X = C[0] + z * ray[0], Y = C[1] + z * ray[1];
        // footprint as on the ground: across z/f, along stretched by the grazing angle (capped)
        const double range = z * cv::norm(ray);
        const double across = z / f;
        const double along = std::min(across * range / height_above_m, across * 16.0);
        const double foot = std::sqrt(across * along) / texel_m;
        const int level = foot < 1.0 ? 0 : std::min(max_level, floor_log2(static_cast<float>(foot)));
        const int lside_log2 = tex.size_log2 - level;
        const int lmask = (1 << lside_log2) - 1;
        const auto* data = reinterpret_cast<const std::uint32_t*>(tex.levels[static_cast<size_t>(level)].data);
        int tx, ty;
        if (tex.tiled) {
          const double sc = tile_scale / static_cast<double>(1 << level);
          tx = static_cast<int>((X - shift.x) * sc + kTexOffset) & lmask;
          ty = static_cast<int>(kTexOffset - (Y - shift.y) * sc) & lmask;
        } else {
          tx = std::clamp(static_cast<int>((X - min_x) * stretch_x) >> level, 0, lmask);
          ty = std::clamp(static_cast<int>((max_y - Y) * stretch_y) >> level, 0, lmask);
        }
        const std::uint32_t texel = data[(ty << lside_log2) | tx];
        if (tex.has_alpha && (texel >> 24) < 128) continue;
        zb[u] = static_cast<float>(iz);
        out[u] = fogged(texel, fog_on ? fog_lut_[std::min<size_t>(fog_lut_.size() - 1, static_cast<size_t>(range * 4.0))] : 0, hz);
        if constexpr (kLabels) {
          if (lab != nullptr) lab[u] = label;
          if (oid != nullptr) oid[u] = oid_value;
        }
      }
    }
  }
}

void label_mask(const cv::Mat& labels, LabelClass label, cv::Mat& mask) {
  CV_Assert(labels.type() == CV_8UC1);
  mask.create(labels.size(), CV_8UC1);
  const auto value = static_cast<std::uint8_t>(label);
  for (int y = 0; y < labels.rows; ++y) {
    const auto* in = labels.ptr<std::uint8_t>(y);
    auto* out = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) out[x] = in[x] == value ? 255 : 0;
  }
}

void colorize_labels(const cv::Mat& labels, cv::Mat& bgr) {
  CV_Assert(labels.type() == CV_8UC1);
  bgr.create(labels.size(), CV_8UC3);
  cv::Vec3b lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = i < kLabelClassCount ? label_color(static_cast<LabelClass>(i)) : cv::Vec3b(255, 255, 255);
  for (int y = 0; y < labels.rows; ++y) {
    const auto* in = labels.ptr<std::uint8_t>(y);
    auto* out = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < labels.cols; ++x) out[x] = lut[in[x]];
  }
}

}  // namespace visnav::sim
