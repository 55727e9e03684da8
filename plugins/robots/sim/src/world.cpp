// World files: YAML → World (textures, regions, walls, trees), region map rasterisation,
// world/route path resolution and the world cache.
#include "visnav_sim/world.hpp"


#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "textures.hpp"
#include "yaml_util.hpp"
#include "visnav/file_io.hpp"

namespace visnav::sim {
namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr const char* kLabelNames[kLabelClassCount] = {"sky",  "path",  "grass", "floor", "pavement",
                                                        "ground", "wall", "fence", "tree",  "obstacle"};

double cross(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

bool segments_intersect(const cv::Point2d& p1, const cv::Point2d& p2, const cv::Point2d& q1, const cv::Point2d& q2) {
  const double d1 = cross(q1, q2, p1), d2 = cross(q1, q2, p2), d3 = cross(p1, p2, q1), d4 = cross(p1, p2, q2);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  auto on = [](const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c, double d) {
    return std::abs(d) < 1e-12 && std::min(a.x, b.x) <= c.x && c.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= c.y &&
           c.y <= std::max(a.y, b.y);
  };
  return on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4);
}

std::string pt(const cv::Point2d& p) {
  std::ostringstream os;
  os << "[" << p.x << ", " << p.y << "]";
  return os.str();
}

/// Error if the closed polygon has two non-adjacent edges that touch or cross.
Status check_simple_polygon(const std::vector<cv::Point2d>& poly, const ConfigNode& node, const std::string& what) {
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    if (cv::norm(poly[i] - poly[(i + 1) % n]) < 1e-9)
      return node_error(node, what + ": repeated vertex " + pt(poly[i]) + " (vertex " + std::to_string(i) + ")");
    for (size_t j = i + 1; j < n; ++j) {
      if (j == i + 1 || (i == 0 && j == n - 1)) continue;  // adjacent edges share a vertex
      if (segments_intersect(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]))
        return node_error(node, what + ": polygon is self-intersecting: edge " + pt(poly[i]) + "-" + pt(poly[(i + 1) % n]) +
                                    " crosses edge " + pt(poly[j]) + "-" + pt(poly[(j + 1) % n]));
    }
  }
  return ok();
}

Result<LabelClass> get_label(const ConfigNode& map, LabelClass fallback) {
  const ConfigNode* n = map.find("class");
  if (n == nullptr) return fallback;
  if (!n->is_scalar()) return node_error(*n, "key 'class': expected a class name");
  auto l = label_class_from_string(n->scalar());
  if (!l || *l == LabelClass::sky) {
    std::string known;
    for (int i = 1; i < kLabelClassCount; ++i) known += std::string(i > 1 ? ", " : "") + kLabelNames[i];
    return node_error(*n, "key 'class': unknown class '" + n->scalar() + "' (known: " + known + ")");
  }
  return *l;
}

Result<int> get_texture(const World& world, const ConfigNode& map, const std::string& what) {
  const ConfigNode* n = map.find("texture");
  if (n == nullptr) return node_error(map, what + ": missing key 'texture'");
  if (!n->is_scalar()) return node_error(*n, "key 'texture': expected a texture name");
  const int idx = world.texture_index(n->scalar());
  if (idx < 0) {
    std::string known;
    for (const auto& t : world.textures) known += (known.empty() ? "" : ", ") + t.name;
    return node_error(*n, "key 'texture': unknown texture '" + n->scalar() + "' (defined: " + known + ")");
  }
  return idx;
}

Result<cv::Vec3b> get_rgb(const ConfigNode& map, const std::string& key, cv::Vec3b fallback_bgr) {
  const ConfigNode* n = map.find(key);
  if (n == nullptr) return fallback_bgr;
  VISNAV_ASSIGN(auto v, as_numbers(*n, key, 3));
  for (double c : v)
    if (c < 0 || c > 255) return node_error(*n, "key '" + key + "': components must be in [0, 255]");
  return cv::Vec3b(static_cast<unsigned char>(v[2]), static_cast<unsigned char>(v[1]), static_cast<unsigned char>(v[0]));
}

Status add_wall(World& world, const cv::Point2d& a, const cv::Point2d& b, double base_m, double top_m, int texture,
                LabelClass label, const std::string& name, const ConfigNode& node) {
  if (cv::norm(a - b) < 1e-6) return node_error(node, name + ": wall has zero length (from " + pt(a) + " to " + pt(b) + ")");
  Wall w;
  w.name = name;
  w.from = a;
  w.to = b;
  w.base_m = base_m;
  w.top_m = top_m;
  w.texture = texture;
  w.label = label;
  w.where = node.where();
  world.walls.push_back(std::move(w));
  return ok();
}

Status parse_walls(World& world, const ConfigNode& list) {
  if (!list.is_sequence()) return node_error(list, "key 'walls': expected a list");
  int index = 0;
  for (const auto& w : list.items()) {
    const std::string what = "wall " + std::to_string(index++);
    VISNAV_TRY(check_keys(w, {"name", "from", "to", "polyline", "closed", "height_m", "base_m", "texture", "class"}, what));
    VISNAV_ASSIGN(const std::string name, get_string(w, "name", what));
    VISNAV_ASSIGN(const double base_m, get_double(w, "base_m", 0.0, 0.0, 1000.0));
    VISNAV_ASSIGN(const double height_m, get_double(w, "height_m", 2.5, 0.01, 1000.0));
    VISNAV_ASSIGN(const int texture, get_texture(world, w, name));
    VISNAV_ASSIGN(const LabelClass label, get_label(w, LabelClass::wall));
    VISNAV_ASSIGN(const bool closed, get_bool(w, "closed", false));
    const ConfigNode* poly = w.find("polyline");
    const ConfigNode* from = w.find("from");
    const ConfigNode* to = w.find("to");
    if ((poly != nullptr) == (from != nullptr || to != nullptr))
      return node_error(w, name + ": give either 'from' and 'to' or 'polyline'");
    std::vector<cv::Point2d> pts;
    if (poly != nullptr) {
      VISNAV_ASSIGN(pts, as_points(*poly, "polyline", 2));
      if (closed) pts.push_back(pts.front());
    } else {
      if (from == nullptr || to == nullptr) return node_error(w, name + ": needs both 'from' and 'to'");
      VISNAV_ASSIGN(const auto a, as_point(*from, "from"));
      VISNAV_ASSIGN(const auto b, as_point(*to, "to"));
      pts = {a, b};
    }
    for (size_t i = 0; i + 1 < pts.size(); ++i)
      VISNAV_TRY(add_wall(world, pts[i], pts[i + 1], base_m, base_m + height_m, texture, label, name,
                          poly != nullptr ? poly->items()[std::min(i, poly->items().size() - 1)] : w));
  }
  return ok();
}

Status parse_trees(World& world, const ConfigNode& list) {
  if (!list.is_sequence()) return node_error(list, "key 'trees': expected a list");
  int index = 0;
  for (const auto& t : list.items()) {
    const std::string what = "tree " + std::to_string(index++);
    VISNAV_TRY(check_keys(t, {"name", "at", "height_m", "width_m", "yaw_deg", "texture", "class"}, what));
    VISNAV_ASSIGN(const std::string name, get_string(t, "name", what));
    const ConfigNode* at = t.find("at");
    if (at == nullptr) return node_error(t, name + ": missing key 'at'");
    VISNAV_ASSIGN(const auto c, as_point(*at, "at"));
    VISNAV_ASSIGN(const double height_m, get_double(t, "height_m", 5.0, 0.1, 100.0));
    VISNAV_ASSIGN(const double width_m, get_double(t, "width_m", 3.0, 0.1, 100.0));
    VISNAV_ASSIGN(const double yaw_deg, get_double(t, "yaw_deg", 0.0, -360.0, 360.0));
    VISNAV_ASSIGN(const int texture, get_texture(world, t, name));
    VISNAV_ASSIGN(const LabelClass label, get_label(t, LabelClass::tree));
    // two crossed billboards
    for (int k = 0; k < 2; ++k) {
      const double a = (yaw_deg + 90.0 * k) * CV_PI / 180.0;
      const cv::Point2d d(std::cos(a) * width_m / 2, std::sin(a) * width_m / 2);
      VISNAV_TRY(add_wall(world, c - d, c + d, 0.0, height_m, texture, label, name, t));
    }
  }
  return ok();
}

// Motion keys of an obstacle: `path` (waypoints after `at`), `speed_mps`, `start_s`, `motion`.
// Returns the mover's index in world.movers, or -1 for a static obstacle.
Result<int> parse_motion(World& world, const ConfigNode& o, const std::string& name, const cv::Point2d& at) {
  const ConfigNode* path = o.find("path");
  if (path == nullptr) {
    for (const char* key : {"speed_mps", "start_s", "motion", "yield_m", "pause_s"})
      if (const ConfigNode* n = o.find(key))
        return node_error(*n, name + ": key '" + key + "' needs 'path' (the waypoints the obstacle moves through)",
                          ErrorCode::missing, "path");
    return -1;
  }
  MovingObstacle m;
  m.name = name;
  VISNAV_ASSIGN(const auto points, as_points(*path, "path", 1));
  m.path.push_back(at);
  for (const auto& p : points) {
    if (cv::norm(p - m.path.back()) < 1e-6)
      return node_error(*path, name + ": key 'path': repeated point " + pt(p) + " (the first segment starts at 'at')",
                        ErrorCode::invalid_value, "path");
    m.path.push_back(p);
  }
  if (o.find("speed_mps") == nullptr) return node_error(o, name + ": a moving obstacle needs 'speed_mps'", ErrorCode::missing, "speed_mps");
  VISNAV_ASSIGN(m.speed_mps, get_double(o, "speed_mps", 1.0, 0.01, 20.0));
  VISNAV_ASSIGN(m.start_s, get_double(o, "start_s", 0.0, 0.0, 1e6));
  VISNAV_ASSIGN(m.yield_m, get_double(o, "yield_m", 0.0, 0.0, 5.0));
  VISNAV_ASSIGN(m.pause_s, get_double(o, "pause_s", 0.0, 0.0, 600.0));
  if (m.pause_s > 0.0 && m.yield_m > 0.0)
    return node_error(*o.find("pause_s"), name + ": key 'pause_s' is for a blind walker; it cannot be combined with 'yield_m'",
                      ErrorCode::inconsistent, "pause_s");
  VISNAV_ASSIGN(const std::string motion, get_string(o, "motion", "once"));
  if (motion == "once") m.motion = MovingObstacle::Motion::once;
  else if (motion == "loop") m.motion = MovingObstacle::Motion::loop;
  else if (motion == "back_and_forth") m.motion = MovingObstacle::Motion::back_and_forth;
  else
    return node_error(*o.find("motion"), name + ": key 'motion': unknown value '" + motion + "' (known: once, loop, back_and_forth)",
                      ErrorCode::out_of_range, "motion");
  world.movers.push_back(std::move(m));
  return static_cast<int>(world.movers.size()) - 1;
}

// `obstacles:` (issue 16): shorthands that expand into closed rings of walls of class
// `obstacle` (so they render, label and collide like any wall). Kinds: `box` (size_m: [length
// along yaw, width]), `van` (a box with a parked van's default size 4.8 x 1.9 x 1.9 m), `post`
// (a regular polygon of `sides` faces inscribed in radius_m) and `person` (a post of a walking
// adult's size: 0.25 m radius, 1.75 m tall, 8 sides). Any kind moves when it has a `path`.
// Each also gets its top (World::caps), so an obstacle lower than the camera shows a closed box
// instead of the inside of its far faces and the ground within its footprint.
Status parse_obstacles(World& world, const ConfigNode& list) {
  if (!list.is_sequence()) return node_error(list, "key 'obstacles': expected a list");
  int index = 0;
  for (const auto& o : list.items()) {
    const std::string what = "obstacle " + std::to_string(index++);
    VISNAV_TRY(check_keys(o, {"name", "kind", "at", "yaw_deg", "size_m", "radius_m", "sides", "height_m", "texture", "path",
                              "speed_mps", "start_s", "motion", "yield_m", "pause_s"},
                          what));
    VISNAV_ASSIGN(const std::string name, get_string(o, "name", what));
    VISNAV_ASSIGN(const std::string kind, get_string(o, "kind", "box"));
    const ConfigNode* at = o.find("at");
    if (at == nullptr) return node_error(o, name + ": missing key 'at'");
    VISNAV_ASSIGN(const auto c, as_point(*at, "at"));
    VISNAV_ASSIGN(const double yaw_deg, get_double(o, "yaw_deg", 0.0, -360.0, 360.0));
    VISNAV_ASSIGN(const int texture, get_texture(world, o, name));
    const double yaw = yaw_deg * CV_PI / 180.0;
    const cv::Point2d ax(std::cos(yaw), std::sin(yaw)), ay(-std::sin(yaw), std::cos(yaw));
    std::vector<cv::Point2d> ring;
    double height_m = 0.0;
    if (kind == "box" || kind == "van") {
      const bool van = kind == "van";
      VISNAV_ASSIGN(height_m, get_double(o, "height_m", van ? 1.9 : 1.0, 0.01, 100.0));
      std::vector<double> size{van ? 4.8 : 0.5, van ? 1.9 : 0.5};
      if (const ConfigNode* n = o.find("size_m")) {
        VISNAV_ASSIGN(size, as_numbers(*n, "size_m", 2));
        if (size[0] < 0.01 || size[1] < 0.01) return node_error(*n, name + ": size_m must be at least 0.01 m");
      }
      if (o.find("radius_m") != nullptr || o.find("sides") != nullptr)
        return node_error(o, name + ": 'radius_m' and 'sides' are for kinds 'post' and 'person'", ErrorCode::invalid_value,
                          o.find("radius_m") != nullptr ? "radius_m" : "sides");
      const double hl = size[0] / 2, hw = size[1] / 2;
      ring = {c - hl * ax - hw * ay, c + hl * ax - hw * ay, c + hl * ax + hw * ay, c - hl * ax + hw * ay};
    } else if (kind == "post" || kind == "person") {
      const bool person = kind == "person";
      VISNAV_ASSIGN(height_m, get_double(o, "height_m", person ? 1.75 : 1.2, 0.01, 100.0));
      VISNAV_ASSIGN(const double radius_m, get_double(o, "radius_m", person ? 0.25 : 0.06, 0.005, 10.0));
      VISNAV_ASSIGN(const double sides_d, get_double(o, "sides", 8.0, 3.0, 64.0));
      if (o.find("size_m") != nullptr)
        return node_error(*o.find("size_m"), name + ": 'size_m' is for kinds 'box' and 'van'", ErrorCode::invalid_value, "size_m");
      const int sides = static_cast<int>(std::lround(sides_d));
      for (int k = 0; k < sides; ++k) {
        const double a = yaw + 2.0 * CV_PI * k / sides;
        ring.push_back(c + radius_m * cv::Point2d(std::cos(a), std::sin(a)));
      }
    } else {
      return node_error(*o.find("kind"), name + ": unknown kind '" + kind + "' (known: box, person, post, van)",
                        ErrorCode::out_of_range, "kind");
    }
    VISNAV_ASSIGN(const int mover, parse_motion(world, o, name, c));
    if (mover >= 0) {
      double r = 0.0;
      for (const auto& q : ring) r = std::max(r, cv::norm(q - c));
      world.movers[static_cast<std::size_t>(mover)].radius_m = r;
    }
    const std::size_t first_wall = world.walls.size();
    for (std::size_t i = 0; i < ring.size(); ++i) {
      VISNAV_TRY(add_wall(world, ring[i], ring[(i + 1) % ring.size()], 0.0, height_m, texture, LabelClass::obstacle,
                          name, o));
      world.walls.back().mover = mover;
    }
    world.caps.push_back(Cap{std::move(ring), height_m, texture, LabelClass::obstacle, first_wall, mover});
  }
  return ok();
}

Status parse_regions(World& world, const ConfigNode& list) {
  if (!list.is_sequence()) return node_error(list, "key 'regions': expected a list");
  int index = 0;
  for (const auto& r : list.items()) {
    const std::string what = "region " + std::to_string(index++);
    VISNAV_TRY(check_keys(r, {"name", "polygon", "polyline", "width_m", "texture", "class"}, what));
    GroundRegion region;
    VISNAV_ASSIGN(region.name, get_string(r, "name", what));
    VISNAV_ASSIGN(region.texture, get_texture(world, r, region.name));
    VISNAV_ASSIGN(region.label, get_label(r, LabelClass::ground));
    region.where = r.where();
    const ConfigNode* poly = r.find("polygon");
    const ConfigNode* line = r.find("polyline");
    if ((poly != nullptr) == (line != nullptr)) return node_error(r, region.name + ": give exactly one of 'polygon' or 'polyline'");
    if (poly != nullptr) {
      VISNAV_ASSIGN(region.polygon, as_points(*poly, "polygon", 3));
      if (region.polygon.size() > 3 && cv::norm(region.polygon.front() - region.polygon.back()) < 1e-9)
        region.polygon.pop_back();  // explicitly closed
      VISNAV_TRY(check_simple_polygon(region.polygon, *poly, "region '" + region.name + "'"));
      if (r.find("width_m") != nullptr) return node_error(*r.find("width_m"), "key 'width_m' only applies to 'polyline' regions");
    } else {
      VISNAV_ASSIGN(region.polyline, as_points(*line, "polyline", 2));
      if (r.find("width_m") == nullptr) return node_error(r, region.name + ": a 'polyline' region needs 'width_m'");
      VISNAV_ASSIGN(region.width_m, get_double(r, "width_m", 1.0, 0.05, 1000.0));
    }
    world.regions.push_back(std::move(region));
  }
  return ok();
}

Status rasterize_regions(World& world, const ConfigNode& root) {
  const double res = world.region_map_resolution_m;
  cv::Rect2d b;
  bool any = false;
  auto extend = [&](const cv::Point2d& p, double margin) {
    cv::Rect2d r(p.x - margin, p.y - margin, 2 * margin, 2 * margin);
    b = any ? (b | r) : r;
    any = true;
  };
  for (const auto& r : world.regions) {
    for (const auto& p : r.polygon) extend(p, res);
    for (const auto& p : r.polyline) extend(p, r.width_m);
  }
  if (!any) {
    world.region_map = cv::Mat(1, 1, CV_16UC1, cv::Scalar(0));
    world.region_map_origin_m = {0, 0};
    return ok();
  }
  b.x -= 2 * res; b.y -= 2 * res; b.width += 4 * res; b.height += 4 * res;
  const double cells = (b.width / res) * (b.height / res);
  if (cells > 64e6)
    return node_error(root, "ground_resolution_m " + std::to_string(res) + " gives a region map of " +
                                std::to_string(static_cast<long long>(cells)) + " cells (max 64M); use a coarser resolution");
  world.region_map_origin_m = {b.x, b.y};
  world.region_map = cv::Mat(static_cast<int>(std::ceil(b.height / res)), static_cast<int>(std::ceil(b.width / res)),
                             CV_16UC1, cv::Scalar(0));
  constexpr int kShift = 3;
  auto to_px = [&](const cv::Point2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x - b.x) / res * (1 << kShift) - 0.5 * (1 << kShift))),
                     static_cast<int>(std::lround((p.y - b.y) / res * (1 << kShift) - 0.5 * (1 << kShift))));
  };
  for (size_t i = 0; i < world.regions.size(); ++i) {
    const auto& r = world.regions[i];
    const cv::Scalar value(static_cast<double>(i + 1));
    if (!r.polygon.empty()) {
      std::vector<cv::Point> pts;
      for (const auto& p : r.polygon) pts.push_back(to_px(p));
      std::vector<std::vector<cv::Point>> polys{pts};
      cv::fillPoly(world.region_map, polys, value, cv::LINE_8, kShift);
    } else {
      const int thickness = std::max(1, static_cast<int>(std::lround(r.width_m / res)));
      for (size_t k = 0; k + 1 < r.polyline.size(); ++k)
        cv::line(world.region_map, to_px(r.polyline[k]), to_px(r.polyline[k + 1]), value, thickness, cv::LINE_8, kShift);
    }
  }
  return ok();
}

Status resolve_seasons(World& world, const ConfigNode& textures) {
  for (const auto& [name, def] : textures.entries()) {
    const ConfigNode* seasons = def.find("seasons");
    if (seasons == nullptr) continue;
    if (!seasons->is_map()) return node_error(*seasons, "key 'seasons': expected a map season: texture");
    const int self = world.texture_index(name);
    for (const auto& [season, target] : seasons->entries()) {
      if (!target.is_scalar()) return node_error(target, "season '" + season + "': expected a texture name");
      const int idx = world.texture_index(target.scalar());
      if (idx < 0) return node_error(target, "season '" + season + "': unknown texture '" + target.scalar() + "'");
      world.textures[static_cast<size_t>(self)].seasons.emplace_back(season, idx);
    }
  }
  return ok();
}

std::vector<std::string> data_roots() {
  std::vector<std::string> roots;
#ifdef VISNAV_SIM_SOURCE_DIR
  roots.emplace_back(VISNAV_SIM_SOURCE_DIR "/config");
#endif
#ifdef VISNAV_SIM_INSTALL_DATA_DIR
  roots.emplace_back(VISNAV_SIM_INSTALL_DATA_DIR);
#endif
  return roots;
}

Result<std::string> resolve_data_path(const std::string& name_or_path, const std::string& relative_to, const std::string& folder) {
  std::vector<std::string> tried;
  auto try_path = [&](const fs::path& p) {
    tried.push_back(p.string());
    std::error_code ec;
    return fs::is_regular_file(p, ec);
  };
  if (name_or_path.empty()) return fail(ErrorCode::missing, "no " + folder.substr(0, folder.size() - 1) + " file given");
  if (try_path(name_or_path)) return name_or_path;
  {
    // A path that exists but is no regular file (/dev/zero, a folder) is named as such, not
    // searched for elsewhere.
    std::error_code ec;
    if (fs::exists(name_or_path, ec))
      return fail(ErrorCode::invalid_value, ErrorLocation{name_or_path},
                  folder.substr(0, folder.size() - 1) + " file is not a regular file; refused before reading");
  }
  if (!relative_to.empty() && fs::path(name_or_path).is_relative()) {
    std::error_code ec;
    fs::path base = fs::is_directory(relative_to, ec) ? fs::path(relative_to) : fs::path(relative_to).parent_path();
    if (try_path(base / name_or_path)) return (base / name_or_path).string();
  }
  for (const auto& root : data_roots()) {
    for (const std::string& candidate : {name_or_path, name_or_path + ".yaml"}) {
      fs::path p = fs::path(root) / folder / candidate;
      if (fs::path(name_or_path).is_relative() && try_path(p)) return p.string();
    }
  }
  std::string list;
  for (const auto& t : tried) list += (list.empty() ? "" : ", ") + t;
  return fail(ErrorCode::not_found, folder.substr(0, folder.size() - 1) + " '" + name_or_path + "' not found (tried: " + list + ")");
}

}  // namespace

const char* to_string(LabelClass label) {
  const int i = static_cast<int>(label);
  return i >= 0 && i < kLabelClassCount ? kLabelNames[i] : "unknown";
}

std::optional<LabelClass> label_class_from_string(std::string_view text) {
  for (int i = 0; i < kLabelClassCount; ++i)
    if (text == kLabelNames[i]) return static_cast<LabelClass>(i);
  return std::nullopt;
}

cv::Vec3b label_color(LabelClass label) {
  switch (label) {
    case LabelClass::sky: return {235, 206, 135};
    case LabelClass::path: return {60, 160, 230};
    case LabelClass::grass: return {60, 170, 60};
    case LabelClass::floor: return {170, 170, 200};
    case LabelClass::pavement: return {140, 140, 140};
    case LabelClass::ground: return {90, 110, 130};
    case LabelClass::wall: return {60, 60, 180};
    case LabelClass::fence: return {40, 90, 140};
    case LabelClass::tree: return {30, 100, 30};
    case LabelClass::obstacle: return {200, 0, 200};
  }
  return {0, 0, 0};
}

double MovingObstacle::walked_at(double time_s) const {
  if (time_s <= start_s) return 0.0;
  const double t = time_s - start_s;
  if (pause_s <= 0.0 || path.size() < 2) return speed_mps * t;
  // The legs in walked order over one cycle: the polyline, then the closing segment (loop) or
  // the polyline backwards (back_and_forth); a pause after each leg.
  const std::size_t n = path.size() - 1;
  const std::size_t legs = motion == Motion::loop ? n + 1 : motion == Motion::back_and_forth ? 2 * n : n;
  auto leg_m = [&](std::size_t k) {
    if (k < n) return cv::norm(path[k + 1] - path[k]);
    if (motion == Motion::loop) return cv::norm(path.front() - path.back());
    return cv::norm(path[2 * n - k] - path[2 * n - k - 1]);  // backwards: leg n-1, n-2, ..., 0
  };
  double cycle_m = 0.0;
  for (std::size_t k = 0; k < legs; ++k) cycle_m += leg_m(k);
  const double cycle_s = cycle_m / speed_mps + static_cast<double>(legs) * pause_s;
  double walked = 0.0, left_s = t;
  if (motion != Motion::once) {
    const double cycles = std::floor(left_s / cycle_s);
    walked = cycles * cycle_m;
    left_s -= cycles * cycle_s;
  }
  for (std::size_t k = 0; k < legs; ++k) {
    const double leg_s = leg_m(k) / speed_mps;
    if (left_s < leg_s) return walked + speed_mps * left_s;
    walked += leg_m(k);
    left_s -= leg_s + pause_s;
    if (left_s < 0.0) return walked;  // standing at the waypoint
  }
  return walked;  // once: at the end
}

cv::Point2d MovingObstacle::position_at(double time_s) const {
  if (path.size() < 2 || time_s <= start_s) return path.empty() ? cv::Point2d(0, 0) : path.front();
  return position_walked(walked_at(time_s));
}

cv::Point2d MovingObstacle::position_walked(double walked_m, cv::Point2d* direction) const {
  if (direction != nullptr) *direction = cv::Point2d(0, 0);
  if (path.size() < 2 || walked_m <= 0.0) {
    if (direction != nullptr && path.size() >= 2) *direction = (path[1] - path[0]) / cv::norm(path[1] - path[0]);
    return path.empty() ? cv::Point2d(0, 0) : path.front();
  }
  // The polyline walked: closed for `loop` (back to the start along the closing segment).
  const bool closed = motion == Motion::loop;
  const std::size_t segments = closed ? path.size() : path.size() - 1;
  double length_m = 0.0;
  for (std::size_t i = 0; i < segments; ++i) length_m += cv::norm(path[(i + 1) % path.size()] - path[i]);
  double s = walked_m;
  bool backwards = false;
  switch (motion) {
    case Motion::once:
      if (s >= length_m) return path.back();  // stands at the end: no direction
      break;
    case Motion::loop: s = std::fmod(s, length_m); break;
    case Motion::back_and_forth: {
      s = std::fmod(s, 2.0 * length_m);
      if (s > length_m) {
        s = 2.0 * length_m - s;
        backwards = true;
      }
      break;
    }
  }
  for (std::size_t i = 0; i < segments; ++i) {
    const cv::Point2d a = path[i], b = path[(i + 1) % path.size()];
    const double seg = cv::norm(b - a);
    if (s <= seg || i + 1 == segments) {
      if (direction != nullptr) *direction = (backwards ? a - b : b - a) / seg;
      return a + (b - a) * (std::min(s, seg) / seg);
    }
    s -= seg;
  }
  return path.back();
}

int World::region_at(double x_m, double y_m) const {
  const double gx = (x_m - region_map_origin_m.x) / region_map_resolution_m;
  const double gy = (y_m - region_map_origin_m.y) / region_map_resolution_m;
  if (gx < 0 || gy < 0 || gx >= region_map.cols || gy >= region_map.rows) return -1;
  return static_cast<int>(region_map.at<std::uint16_t>(static_cast<int>(gy), static_cast<int>(gx))) - 1;
}

LabelClass World::ground_label_at(double x_m, double y_m) const {
  const int r = region_at(x_m, y_m);
  return r < 0 ? default_label : regions[static_cast<size_t>(r)].label;
}

int World::texture_index(std::string_view wanted) const {
  for (size_t i = 0; i < textures.size(); ++i)
    if (textures[i].name == wanted) return static_cast<int>(i);
  return -1;
}

cv::Rect2d World::bounds() const {
  cv::Rect2d b;
  bool any = false;
  auto extend = [&](const cv::Point2d& p) {
    cv::Rect2d r(p.x, p.y, 0, 0);
    if (!any) { b = r; any = true; return; }
    const double x0 = std::min(b.x, p.x), y0 = std::min(b.y, p.y);
    const double x1 = std::max(b.x + b.width, p.x), y1 = std::max(b.y + b.height, p.y);
    b = cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  };
  for (const auto& r : regions) {
    for (const auto& p : r.polygon) extend(p);
    for (const auto& p : r.polyline) { extend(p + cv::Point2d(r.width_m, r.width_m)); extend(p - cv::Point2d(r.width_m, r.width_m)); }
  }
  for (const auto& w : walls) { extend(w.from); extend(w.to); }
  extend({start.x_m, start.y_m});
  return b;
}

// World and route files are YAML read by the SDK's parser: the same syntax errors, duplicate-key
// check and alias-bomb limits (issue 17) as run configs.
Result<ConfigNode> parse_yaml_text(std::string_view text, const std::string& file_label) {
  return visnav::parse_yaml_string(text, file_label);
}

Result<ConfigNode> parse_yaml_path(const std::string& path) { return visnav::parse_yaml_file(path); }

std::string skimage_data_dir() {
  if (const char* env = std::getenv("VISNAV_SKIMAGE_DIR"); env != nullptr && *env != '\0') return env;
  return "/usr/lib/python3/dist-packages/skimage/data";
}

Result<std::shared_ptr<const World>> parse_world(std::string_view yaml_text, const std::string& file_label,
                                                 const std::string& base_dir) {
  VISNAV_ASSIGN(ConfigNode doc, parse_yaml_text(yaml_text, file_label));
  if (!doc.is_map() || doc.find("world") == nullptr)
    return node_error(doc, "a world file has one top-level key 'world'", ErrorCode::missing, "world");
  VISNAV_TRY(check_keys(doc, {"world"}, "the world file"));
  const ConfigNode& root = *doc.find("world");
  VISNAV_TRY(check_keys(root,
                        {"name", "ground_resolution_m", "sky_zenith", "sky_horizon", "fog_distance_m", "default_ground",
                         "textures", "regions", "walls", "trees", "obstacles", "start"},
                        "'world'"));
  auto world = std::make_shared<World>();
  world->file = file_label;
  VISNAV_ASSIGN(world->name, get_string(root, "name", fs::path(file_label).stem().string()));
  VISNAV_ASSIGN(world->region_map_resolution_m, get_double(root, "ground_resolution_m", 0.05, 0.005, 1.0));
  VISNAV_ASSIGN(world->fog_distance_m, get_double(root, "fog_distance_m", 0.0, 0.0, 1e6));
  VISNAV_ASSIGN(world->sky_zenith_bgr, get_rgb(root, "sky_zenith", world->sky_zenith_bgr));
  VISNAV_ASSIGN(world->sky_horizon_bgr, get_rgb(root, "sky_horizon", world->sky_horizon_bgr));

  const ConfigNode* textures = root.find("textures");
  if (textures == nullptr || !textures->is_map() || textures->entries().empty())
    return node_error(textures != nullptr ? *textures : root, "'world' needs a non-empty map 'textures'");
  for (const auto& [name, def] : textures->entries()) {
    VISNAV_ASSIGN(Texture t, make_texture(name, def, base_dir));
    world->textures.push_back(std::move(t));
  }
  VISNAV_TRY(resolve_seasons(*world, *textures));

  const ConfigNode* ground = root.find("default_ground");
  if (ground == nullptr) return node_error(root, "'world' needs 'default_ground: {texture: ..., class: ...}'");
  VISNAV_TRY(check_keys(*ground, {"texture", "class"}, "'default_ground'"));
  VISNAV_ASSIGN(world->default_texture, get_texture(*world, *ground, "default_ground"));
  VISNAV_ASSIGN(world->default_label, get_label(*ground, LabelClass::ground));

  if (const ConfigNode* n = root.find("regions")) VISNAV_TRY(parse_regions(*world, *n));
  if (world->regions.size() >= 0x7FFE) return node_error(root, "too many regions (max 32765)");
  if (const ConfigNode* n = root.find("walls")) VISNAV_TRY(parse_walls(*world, *n));
  if (const ConfigNode* n = root.find("trees")) VISNAV_TRY(parse_trees(*world, *n));
  if (const ConfigNode* n = root.find("obstacles")) VISNAV_TRY(parse_obstacles(*world, *n));
  if (world->walls.size() >= 0x7FFF) return node_error(root, "too many walls (max 32766)");
  if (const ConfigNode* n = root.find("start")) {
    VISNAV_ASSIGN(auto s, as_numbers(*n, "start", 3));
    world->start = Pose2D{s[0], s[1], s[2] * CV_PI / 180.0};
  }
  VISNAV_TRY(rasterize_regions(*world, root));
  return std::shared_ptr<const World>(std::move(world));
}

Result<std::shared_ptr<const World>> load_world(const std::string& path) {
  VISNAV_ASSIGN(const std::string text, visnav::read_text_file(path, visnav::kMaxConfigFileBytes, "world"));
  return parse_world(text, path, fs::path(path).parent_path().string());
}

Result<std::shared_ptr<const World>> load_world_cached(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::pair<fs::file_time_type, std::shared_ptr<const World>>> cache;
  std::error_code ec;
  const std::string key = fs::weakly_canonical(path, ec).string();
  const auto mtime = fs::last_write_time(path, ec);
  std::lock_guard lock(mutex);
  auto it = cache.find(key);
  if (it != cache.end() && it->second.first == mtime) return it->second.second;
  VISNAV_ASSIGN(auto world, load_world(path));
  cache[key] = {mtime, world};
  return world;
}

Result<std::shared_ptr<const World>> add_obstacles(const World& base, const std::string& obstacles_path) {
  VISNAV_ASSIGN(ConfigNode doc, parse_yaml_path(obstacles_path));
  if (!doc.is_map() || doc.find("obstacles") == nullptr)
    return node_error(doc, "an obstacle file has one top-level key 'obstacles'", ErrorCode::missing, "obstacles");
  VISNAV_TRY(check_keys(doc, {"obstacles"}, "the obstacle file"));
  // Textures and region map are shared (cv::Mat headers), walls and movers copied: cheap.
  auto world = std::make_shared<World>(base);
  VISNAV_TRY(parse_obstacles(*world, *doc.find("obstacles")));
  if (world->walls.size() >= 0x7FFF) return node_error(doc, "too many walls (max 32766)");
  return std::shared_ptr<const World>(std::move(world));
}

Result<std::shared_ptr<const World>> load_world_with_obstacles(const std::string& world_path, const std::string& obstacles_path,
                                                               const std::string& relative_to) {
  VISNAV_ASSIGN(auto world, load_world_cached(world_path));
  if (obstacles_path.empty()) return world;
  VISNAV_ASSIGN(const std::string path, resolve_data_path(obstacles_path, relative_to, "obstacles"));
  return add_obstacles(*world, path);
}

Result<std::string> resolve_world_path(const std::string& name_or_path, const std::string& relative_to) {
  return resolve_data_path(name_or_path, relative_to, "worlds");
}

Status check_world_file(const std::string& name_or_path, const ConfigNode& params) {
  const ConfigNode* key = params.is_map() ? params.find("world") : nullptr;
  const SourceLocation& at = key != nullptr ? key->where() : params.where();
  const ErrorLocation where{at.file, at.line, "world"};
  const std::string prefix = params.where().str() + ": key 'world': ";
  auto path = resolve_world_path(name_or_path, params.where().file);
  if (!path) return Error{prefix + path.error().message, ErrorCode::not_found, where};
  if (auto world = load_world_cached(*path); !world) return Error{prefix + world.error().message, ErrorCode::parse_error, where};
  return ok();
}

Result<std::string> resolve_route_path(const std::string& name_or_path, const std::string& relative_to) {
  return resolve_data_path(name_or_path, relative_to, "routes");
}

}  // namespace visnav::sim
