// Procedural worlds (generate.hpp). Everything is laid out in a local frame around the route
// polygon (the first side along +x), then rotated and shifted once when written, so the checks
// during placement are simple and the written worlds still face every direction.
#include "visnav_sim/generate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "visnav_sim/commands.hpp"
#include "visnav_sim/route.hpp"

namespace visnav::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

// A portable generator: std::uniform_real_distribution's output differs between standard
// libraries; this one does not, so a seed names the same world everywhere.
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : state_(seed * 0x9E3779B97F4A7C15ULL + 0x632BE59BD9B4E019ULL) {}
  std::uint64_t next() {  // splitmix64
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53; }
  int integer(int lo, int hi) { return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1)); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
  template <class T>
  const T& pick(const std::vector<T>& v) { return v[static_cast<std::size_t>(integer(0, static_cast<int>(v.size()) - 1))]; }

 private:
  std::uint64_t state_;
};

using P = cv::Point2d;

double point_segment_m(const P& p, const P& a, const P& b) {
  const P d = b - a;
  const double len2 = d.dot(d);
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return cv::norm(p - (a + d * t));
}

bool segments_cross(const P& a, const P& b, const P& c, const P& d) {
  auto orient = [](const P& p, const P& q, const P& r) { return (q - p).cross(r - p); };
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  return ((o1 > 0) != (o2 > 0)) && ((o3 > 0) != (o4 > 0));
}

double segment_segment_m(const P& a, const P& b, const P& c, const P& d) {
  if (segments_cross(a, b, c, d)) return 0.0;
  return std::min({point_segment_m(a, c, d), point_segment_m(b, c, d), point_segment_m(c, a, b), point_segment_m(d, a, b)});
}

/// Distance of a segment to a closed polyline.
double segment_route_m(const P& a, const P& b, const std::vector<P>& route) {
  double best = 1e18;
  for (std::size_t i = 0; i + 1 < route.size(); ++i) best = std::min(best, segment_segment_m(a, b, route[i], route[i + 1]));
  return best;
}

double point_route_m(const P& p, const std::vector<P>& route) {
  double best = 1e18;
  for (std::size_t i = 0; i + 1 < route.size(); ++i) best = std::min(best, point_segment_m(p, route[i], route[i + 1]));
  return best;
}

cv::Rect2d bounding_box(const std::vector<P>& points) {
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& p : points) { x0 = std::min(x0, p.x); y0 = std::min(y0, p.y); x1 = std::max(x1, p.x); y1 = std::max(y1, p.y); }
  return {x0, y0, x1 - x0, y1 - y0};
}

/// Whether p is inside a convex ring (either orientation).
bool inside_convex(const std::vector<P>& ring, const P& p) {
  int sign = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const double c = (ring[(i + 1) % ring.size()] - ring[i]).cross(p - ring[i]);
    const int s = c > 0 ? 1 : -1;
    if (sign == 0) sign = s;
    else if (s != sign) return false;
  }
  return true;
}

struct RegionSpec {
  std::string name, texture, label;
  std::vector<P> polygon;   ///< or
  std::vector<P> polyline;  ///< with width_m
  double width_m = 0.0;
};
struct WallSpec {
  std::string name, texture, label = "wall";
  std::vector<P> polyline;
  bool closed = false;
  double height_m = 2.5, base_m = 0.0;
};
struct TreeSpec {
  P at;
  double height_m = 5, width_m = 3, yaw_deg = 0;
  std::string texture;
};
struct ObstacleSpec {
  std::string name, kind, texture;
  P at;
  double yaw_deg = 0.0;
  std::vector<P> path;  ///< walkers
  double speed_mps = 0.0, start_s = 0.0;
};
struct Waypoint {
  P at;
  std::string kind;
};

/// The world under construction (local frame) with what placement checks against.
struct Layout {
  std::string kind;
  std::vector<P> route;       ///< closed: route.front() == route.back()
  std::vector<Waypoint> waypoints;
  std::vector<RegionSpec> regions;
  std::vector<WallSpec> walls;
  std::vector<TreeSpec> trees;
  std::vector<ObstacleSpec> obstacles;
  std::vector<std::pair<P, P>> solid;  ///< every wall segment (collisions, clearance)
  std::vector<P> trunks;
  std::vector<std::string> texture_lines;
  std::string default_ground;
  std::string sky_zenith, sky_horizon;
  double fog_m = 250.0;
  std::string lighting;
  std::vector<std::string> notes;  ///< texture/material choices for the summary

  bool clear_of_route(const P& a, const P& b, double clearance_m) const { return segment_route_m(a, b, route) >= clearance_m; }
  double solid_distance(const P& p) const {
    double best = 1e18;
    for (const auto& [a, b] : solid) best = std::min(best, point_segment_m(p, a, b));
    for (const auto& t : trunks) best = std::min(best, cv::norm(p - t));
    return best;
  }
  bool segment_clear_of_solid(const P& a, const P& b, double gap_m) const {
    for (const auto& [c, d] : solid)
      if (segment_segment_m(a, b, c, d) < gap_m) return false;
    for (const auto& t : trunks)
      if (point_segment_m(t, a, b) < gap_m) return false;
    return true;
  }
  void add_wall(WallSpec w) {
    for (std::size_t i = 0; i + 1 < w.polyline.size(); ++i) solid.emplace_back(w.polyline[i], w.polyline[i + 1]);
    if (w.closed && w.polyline.size() > 2) solid.emplace_back(w.polyline.back(), w.polyline.front());
    walls.push_back(std::move(w));
  }
};

std::string colour(double r, double g, double b) {
  std::ostringstream s;
  s << "[" << std::clamp(static_cast<int>(std::lround(r)), 0, 255) << ", " << std::clamp(static_cast<int>(std::lround(g)), 0, 255)
    << ", " << std::clamp(static_cast<int>(std::lround(b)), 0, 255) << "]";
  return s.str();
}

/// Lighting of a world: a colour multiplier applied to every texture colour and a sky.
struct Light {
  double gain = 1.0;
  double r = 1.0, g = 1.0, b = 1.0;
  std::string c(double red, double green, double blue) const { return colour(red * gain * r, green * gain * g, blue * gain * b); }
};

/// Texture palette of one world: photographs of python3-skimage (grass, gravel, brick and, as
/// posters indoors, the colour photos) and procedural patterns with drawn colours and scales.
void add_textures(Layout& L, Draw& d, const Light& li) {
  auto& t = L.texture_lines;
  const double green = d.uniform(0.0, 1.0);  // lush … dry
  t.push_back("grass: {image: \"skimage:grass\", color: " + li.c(92 + 70 * green, 135 - 10 * green, 58 + 5 * green) +
              ", size_m: " + std::to_string(d.uniform(1.2, 2.2)).substr(0, 4) +
              ", seasons: {winter: snow, autumn: grass_autumn}}");
  t.push_back("grass_autumn: {image: \"skimage:grass\", color: " + li.c(150, 128, 62) + ", size_m: 1.6}");
  t.push_back("meadow: {procedural: noise, color: " + li.c(80 + 40 * green, 120, 50) + ", color2: " + li.c(60, 95, 40) +
              ", size_m: 3.0, feature_m: 0.25, detail: 0.2, seasons: {winter: snow}}");
  t.push_back("snow: {procedural: noise, color: " + li.c(240, 242, 246) + ", color2: " + li.c(200, 206, 218) +
              ", size_m: 3.0, feature_m: 0.3, detail: 0.12}");
  t.push_back("snow_path: {procedural: noise, color: " + li.c(196, 192, 190) + ", color2: " + li.c(150, 146, 142) +
              ", size_m: 2.0, feature_m: 0.06, detail: 0.3}");
  t.push_back("gravel: {image: \"skimage:gravel\", color: " + li.c(d.uniform(140, 175), d.uniform(130, 160), d.uniform(110, 140)) +
              ", size_m: " + std::to_string(d.uniform(1.0, 1.8)).substr(0, 4) + ", seasons: {winter: snow_path}}");
  t.push_back("asphalt: {procedural: noise, color: " + li.c(88, 88, 92) + ", color2: " + li.c(62, 62, 66) +
              ", size_m: 2.0, feature_m: 0.08, detail: 0.3, seasons: {winter: snow_path}}");
  t.push_back("dirt: {procedural: noise, color: " + li.c(150, 120, 86) + ", color2: " + li.c(110, 86, 60) +
              ", size_m: 2.5, feature_m: 0.12, detail: 0.28, seasons: {winter: snow_path}}");
  t.push_back("pavers: {image: \"skimage:brick\", color: " + li.c(d.uniform(130, 170), d.uniform(120, 150), d.uniform(110, 140)) +
              ", size_m: " + std::to_string(d.uniform(2.2, 3.6)).substr(0, 4) + ", contrast: 1.2}");
  t.push_back("slabs: {procedural: tiles, color: " + li.c(176, 172, 164) + ", color2: " + li.c(120, 118, 112) +
              ", size_m: 4.0, cell_m: " + std::to_string(d.uniform(0.4, 0.8)).substr(0, 4) + ", grout_m: 0.015, detail: 0.15}");
  const double fr = d.uniform(150, 215), fg = d.uniform(140, 205), fb = d.uniform(120, 195);
  t.push_back("floor: {procedural: tiles, color: " + li.c(fr, fg, fb) + ", color2: " + li.c(fr * 0.55, fg * 0.55, fb * 0.55) +
              ", size_m: 4.0, cell_m: " + std::to_string(d.uniform(0.3, 0.7)).substr(0, 4) +
              ", grout_m: 0.012, detail: 0.1, pixels: 1024, seed: " + std::to_string(d.integer(1, 999)) + "}");
  t.push_back("floor_wood: {procedural: planks, color: " + li.c(168, 124, 82) + ", color2: " + li.c(96, 66, 40) +
              ", size_m: 2.4, cell_m: 0.18, grout_m: 0.01, detail: 0.15, pixels: 1024}");
  t.push_back("brick: {procedural: bricks, color: " + li.c(d.uniform(150, 185), d.uniform(70, 100), d.uniform(50, 75)) + ", color2: " +
              li.c(205, 200, 190) + ", size_m: 2.4, cell_m: 0.3, cell_h_m: 0.1, grout_m: 0.012, detail: 0.18, pixels: 1024}");
  t.push_back("brick_photo: {image: \"skimage:brick\", size_m: " + std::to_string(d.uniform(1.5, 3.0)).substr(0, 4) + "}");
  t.push_back("indoor: {procedural: bricks, color: " + li.c(d.uniform(200, 230), d.uniform(195, 222), d.uniform(180, 205)) +
              ", color2: " + li.c(150, 146, 138) + ", size_m: 2.4, cell_m: " + std::to_string(d.uniform(0.3, 0.6)).substr(0, 4) +
              ", cell_h_m: 0.2, grout_m: 0.015, detail: 0.15, pixels: 1024, seed: " + std::to_string(d.integer(1, 999)) + "}");
  t.push_back("plaster: {procedural: noise, color: " + li.c(d.uniform(190, 225), d.uniform(185, 220), d.uniform(170, 210)) +
              ", color2: " + li.c(150, 150, 145) + ", size_m: 2.0, feature_m: 0.2, detail: 0.2}");
  for (int k = 0; k < 3; ++k) {
    const double r = d.uniform(140, 225), g = d.uniform(140, 215), b = d.uniform(130, 210);
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << "facade" << k << ": {procedural: facade, color: " << li.c(r, g, b)
      << ", color2: " << li.c(r * 0.85, g * 0.85, b * 0.85) << ", size_m: 8.0, bay_m: " << d.uniform(1.6, 3.0)
      << ", storey_m: " << d.uniform(3.2, 4.2) << ", window_w_m: " << d.uniform(0.8, 1.5) << ", window_h_m: " << d.uniform(1.2, 2.2)
      << ", sill_m: " << d.uniform(0.7, 1.1) << ", pixels: 1024, seed: " << d.integer(1, 999) << "}";
    t.push_back(s.str());
  }
  t.push_back("concrete: {procedural: noise, color: " + li.c(172, 170, 164) + ", color2: " + li.c(132, 130, 126) +
              ", size_m: 2.0, feature_m: 0.1, detail: 0.25}");
  t.push_back("fence: {procedural: planks, color: " + li.c(d.uniform(120, 160), d.uniform(85, 110), d.uniform(50, 70)) + ", color2: " +
              li.c(60, 42, 28) + ", size_m: 1.2, cell_m: 0.15, grout_m: 0.02}");
  for (int k = 0; k < 2; ++k) {
    const std::string n = "tree" + std::to_string(k);
    t.push_back(n + ": {procedural: tree, color: " + li.c(d.uniform(40, 80), d.uniform(95, 135), d.uniform(30, 55)) +
                ", size_m: 4.0, pixels: 256, seed: " + std::to_string(d.integer(1, 999)) + ", seasons: {autumn: " + n +
                "_autumn, winter: " + n + "_winter}}");
    t.push_back(n + "_autumn: {procedural: tree, color: " + li.c(190, 110, 40) + ", size_m: 4.0, pixels: 256, seed: " +
                std::to_string(d.integer(1, 999)) + "}");
    t.push_back(n + "_winter: {procedural: tree, color: " + li.c(214, 220, 226) + ", size_m: 4.0, pixels: 256, seed: " +
                std::to_string(d.integer(1, 999)) + "}");
  }
  for (const char* photo : {"coffee", "rocket", "camera", "motorcycle_left"})
    t.push_back(std::string("poster_") + photo + ": {image: \"skimage:" + photo + (std::string(photo) == "rocket" ? ".jpg" : "") + "\", stretch: true}");
}

/// The route polygon (local frame, counter-clockwise or clockwise, first side along +x from the
/// origin) for a kind.
std::vector<P> route_polygon(Draw& d, const std::string& kind) {
  double w = 0, h = 0, jitter = 0;
  if (kind == "indoor") { w = d.uniform(12, 20); h = d.uniform(9, 14); jitter = 0.5; }
  else if (kind == "mixed") { w = d.uniform(20, 28); h = d.uniform(12, 18); jitter = 1.0; }
  else { w = d.uniform(16, 28); h = d.uniform(12, 20); jitter = 1.2; }
  std::vector<P> poly;
  if (d.chance(0.4)) {  // L shape: the far corner cut out
    const double cw = w * d.uniform(0.3, 0.45), ch = h * d.uniform(0.3, 0.45);
    poly = {{0, 0}, {w, 0}, {w, h - ch}, {w - cw, h - ch}, {w - cw, h}, {0, h}};
  } else {
    poly = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  }
  for (std::size_t i = 2; i < poly.size(); ++i) poly[i] += P(d.uniform(-jitter, jitter), d.uniform(-jitter, jitter));
  poly[1] += P(d.uniform(-jitter, jitter), 0.0);  // keep the first side on +x
  if (d.chance(0.5)) {  // clockwise: mirror in y (the first side stays on +x)
    for (auto& p : poly) p.y = -p.y;
  }
  return poly;
}

/// Walls along a straight run of the route at `offset` either side (a corridor or a building's
/// long sides), from t0 to t1 metres along side a→b.
void corridor(Layout& L, const P& a, const P& b, double t0, double t1, double half_width_m, const std::string& texture,
              double height_m, const std::string& name) {
  const P u = (b - a) / cv::norm(b - a), n(-u.y, u.x);
  for (int s : {-1, 1}) {
    WallSpec w;
    w.name = name + (s < 0 ? "_right" : "_left");
    w.texture = texture;
    w.height_m = height_m;
    w.polyline = {a + u * t0 + n * (s * half_width_m), a + u * t1 + n * (s * half_width_m)};
    L.add_wall(std::move(w));
  }
}

/// Rejection-samples an axis-free rectangle (building, pillar, bench) around the route.
std::optional<std::vector<P>> place_box(Layout& L, Draw& d, const cv::Rect2d& area, double len_lo, double len_hi,
                                        double wid_lo, double wid_hi, double clearance_m, double gap_m) {
  for (int attempt = 0; attempt < 60; ++attempt) {
    const P c(d.uniform(area.x, area.x + area.width), d.uniform(area.y, area.y + area.height));
    const double l = d.uniform(len_lo, len_hi) / 2, w = d.uniform(wid_lo, wid_hi) / 2, a = d.uniform(0, kPi);
    const P u(std::cos(a), std::sin(a)), n(-u.y, u.x);
    std::vector<P> ring = {c - u * l - n * w, c + u * l - n * w, c + u * l + n * w, c - u * l + n * w};
    bool ok = point_route_m(c, L.route) >= clearance_m;
    for (int i = 0; i < 4 && ok; ++i) {
      const P& p = ring[static_cast<std::size_t>(i)];
      const P& q = ring[static_cast<std::size_t>((i + 1) % 4)];
      ok = L.clear_of_route(p, q, clearance_m) && L.segment_clear_of_solid(p, q, gap_m);
    }
    // a box must not enclose a part of the route (the route would run inside it)
    if (ok && inside_convex(ring, L.route[0])) ok = false;
    if (ok) return ring;
  }
  return std::nullopt;
}

void place_trees(Layout& L, Draw& d, const cv::Rect2d& area, int count, double clearance_m) {
  for (int k = 0, attempts = 0; k < count && attempts < count * 30; ++attempts) {
    const P at(d.uniform(area.x, area.x + area.width), d.uniform(area.y, area.y + area.height));
    if (point_route_m(at, L.route) < clearance_m || L.solid_distance(at) < 1.5) continue;
    TreeSpec t;
    t.at = at;
    t.height_m = d.uniform(4.5, 8.0);
    t.width_m = d.uniform(3.0, 5.0);
    t.yaw_deg = d.uniform(0, 90);
    t.texture = d.chance(0.5) ? "tree0" : "tree1";
    L.trees.push_back(t);
    L.trunks.push_back(at);
    ++k;
  }
}

/// Route waypoints of a polygon whose sides carry `path` flags: the route starts in the middle
/// of side 0; on a path side the path leg starts 3 m after the corner and ends 3 m before the
/// next, so corners are driven feature-based (the path follower would round them).
void make_waypoints(Layout& L, const std::vector<P>& poly, const std::vector<bool>& path_side) {
  const std::size_t n = poly.size();
  const P start = (poly[0] + poly[1]) * 0.5;
  struct Side { P a, b; bool path; bool first_half; bool second_half; };
  std::vector<Side> sides;
  sides.push_back({start, poly[1], path_side[0], false, true});
  for (std::size_t i = 1; i < n; ++i) sides.push_back({poly[i], poly[(i + 1) % n], path_side[i], false, false});
  sides.push_back({poly[0], start, path_side[0], true, false});
  constexpr double kCornerLeg_m = 3.0, kMinPathLeg_m = 4.0;
  for (const Side& s : sides) {
    const double len = cv::norm(s.b - s.a);
    const P u = (s.b - s.a) / len;
    // the half sides at the start have no corner at the start point
    const double head = s.second_half ? 0.0 : kCornerLeg_m, tail = s.first_half ? 0.0 : kCornerLeg_m;
    if (s.path && len - head - tail >= kMinPathLeg_m) {
      if (head > 0) L.waypoints.push_back({s.a, "feature"});
      L.waypoints.push_back({s.a + u * head, "path"});
      if (tail > 0) L.waypoints.push_back({s.b - u * tail, "feature"});
    } else {
      L.waypoints.push_back({s.a, "feature"});
    }
  }
  // the last side ends at the start (the route is closed: `closed: true` drives back to it)
  L.route.clear();
  for (const auto& w : L.waypoints) L.route.push_back(w.at);
  L.route.push_back(L.waypoints.front().at);
}

/// Outdoor step 1: which sides of the route polygon carry a path (and, for mixed, `hall_side`,
/// the side that runs through a building; `poly.size()` if none).
std::vector<bool> choose_path_sides(Draw& d, const std::vector<P>& poly, bool mixed, std::size_t& hall_side) {
  const std::size_t n = poly.size();
  std::vector<bool> path_side(n, false);
  hall_side = n;  // mixed: the side that runs through a building
  if (mixed) {
    std::vector<std::size_t> long_sides;
    for (std::size_t i = 1; i < n; ++i)
      if (cv::norm(poly[(i + 1) % n] - poly[i]) >= 12.0) long_sides.push_back(i);
    if (!long_sides.empty()) hall_side = d.pick(long_sides);
  }
  int paths = 0;
  for (std::size_t i = 0; i < n; ++i) {
    path_side[i] = i != hall_side && d.chance(mixed ? 0.5 : 0.65);
    paths += path_side[i] ? 1 : 0;
  }
  if (paths == 0) path_side[hall_side == 1 ? 2 : 1] = true;
  return path_side;
}

/// Outdoor step 2: the ground texture, the path regions on the path sides, squares under some
/// feature sides and side paths leaving corners.
void add_ground_regions(Layout& L, Draw& d, const std::vector<P>& poly, const std::vector<bool>& path_side,
                        std::size_t hall_side) {
  const std::size_t n = poly.size();
  const std::vector<std::string> ground = {"grass", "grass", "meadow"};
  L.default_ground = d.pick(ground);
  L.notes.push_back("ground " + L.default_ground);
  const std::string path_texture = d.pick(std::vector<std::string>{"gravel", "gravel", "asphalt", "dirt"});
  L.notes.push_back("paths " + path_texture);
  const double path_width = d.uniform(1.8, 3.0);
  // squares under some feature sides: an open paved area without a path
  for (std::size_t i = 0; i < n; ++i) {
    if (path_side[i] || i == hall_side || !d.chance(0.6)) continue;
    const P a = poly[i], b = poly[(i + 1) % n];
    const P u = (b - a) / cv::norm(b - a), nn(-u.y, u.x);
    const double before = d.uniform(2, 5), after = d.uniform(2, 5), left = d.uniform(3, 7), right = d.uniform(3, 7);
    RegionSpec r;
    r.name = "square_" + std::to_string(i);
    r.texture = d.chance(0.5) ? "pavers" : "slabs";
    r.label = "pavement";
    r.polygon = {a - u * before - nn * right, b + u * after - nn * right, b + u * after + nn * left, a - u * before + nn * left};
    L.regions.push_back(std::move(r));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!path_side[i]) continue;
    const P a = poly[i], b = poly[(i + 1) % n];
    const P u = (b - a) / cv::norm(b - a);
    RegionSpec r;
    r.name = "path_" + std::to_string(i);
    r.texture = path_texture;
    r.label = "path";
    r.width_m = path_width;
    r.polyline = {a - u * 1.0, b + u * 1.0};
    L.regions.push_back(std::move(r));
  }
  // side paths leaving corners (junctions the route passes)
  for (int k = d.integer(0, 2); k > 0; --k) {
    const std::size_t i = static_cast<std::size_t>(d.integer(0, static_cast<int>(n) - 1));
    const P c = poly[i];
    const P centre = [&] { P s(0, 0); for (const auto& p : poly) s += p; return s / static_cast<double>(n); }();
    const P out = (c - centre) / cv::norm(c - centre);
    const double a = d.uniform(-0.6, 0.6);
    const P dir(out.x * std::cos(a) - out.y * std::sin(a), out.x * std::sin(a) + out.y * std::cos(a));
    RegionSpec r;
    r.name = "side_path_" + std::to_string(k);
    r.texture = path_texture;
    r.label = "path";
    r.width_m = d.uniform(1.5, 2.5);
    r.polyline = {c, c + dir * d.uniform(8, 16)};
    L.regions.push_back(std::move(r));
  }
}

/// Outdoor step 3 (mixed): the route runs through a building hall on `hall_side` with a door at
/// each end.
void add_hall(Layout& L, Draw& d, const std::vector<P>& poly, std::size_t hall_side, const GenerateParams& gp) {
  const std::size_t n = poly.size();
  const P a = poly[hall_side], b = poly[(hall_side + 1) % n];
  const double len = cv::norm(b - a);
  const P u = (b - a) / len, nn(-u.y, u.x);
  const double t0 = 3.0, t1 = len - 3.0, hw = d.uniform(3.0, 5.0), door = gp.corridor_half_width_m, height = d.uniform(5, 9);
  const std::string facade = "facade" + std::to_string(d.integer(0, 2));
  RegionSpec floor;
  floor.name = "hall_floor";
  floor.texture = d.chance(0.7) ? "floor" : "floor_wood";
  floor.label = "floor";
  floor.polygon = {a + u * t0 - nn * hw, a + u * t1 - nn * hw, a + u * t1 + nn * hw, a + u * t0 + nn * hw};
  L.regions.push_back(std::move(floor));
  corridor(L, a, b, t0, t1, hw, "indoor", height - 1, "hall");
  corridor(L, a, b, t0 - 0.3, t1 + 0.3, hw + 0.3, facade, height, "hall_facade");
  for (double t : {t0, t1}) {
    const double to = t == t0 ? t0 - 0.3 : t1 + 0.3;
    for (int s : {-1, 1}) {
      WallSpec inner{"hall_end_" + std::to_string(static_cast<int>(t)) + (s < 0 ? "_r" : "_l"), "indoor", "wall",
                     {a + u * t + nn * (s * door), a + u * t + nn * (s * hw)}, false, height - 1, 0.0};
      L.add_wall(std::move(inner));
      WallSpec outer{"hall_facade_end_" + std::to_string(static_cast<int>(t)) + (s < 0 ? "_r" : "_l"), facade, "wall",
                     {a + u * to + nn * (s * door), a + u * to + nn * (s * (hw + 0.3))}, false, height, 0.0};
      L.add_wall(std::move(outer));
      WallSpec jamb{"hall_jamb_" + std::to_string(static_cast<int>(t)) + (s < 0 ? "_r" : "_l"), "concrete", "wall",
                    {a + u * t + nn * (s * door), a + u * to + nn * (s * door)}, false, 2.6, 0.0};
      L.add_wall(std::move(jamb));
    }
    // the lintel above the door: passed under (body_height_m 0.6), not a solid segment
    L.walls.push_back(WallSpec{"hall_lintel_" + std::to_string(static_cast<int>(t)), facade, "wall",
                               {a + u * to - nn * door, a + u * to + nn * door}, false, height - 2.6, 2.6});
  }
  L.notes.push_back("hall through side " + std::to_string(hall_side));
}

/// Outdoor step 4: scenery around the route: buildings, fences, trees, benches.
void add_outdoor_scenery(Layout& L, Draw& d, const std::vector<P>& poly, const GenerateParams& gp) {
  const std::size_t n = poly.size();
  const cv::Rect2d box = bounding_box(poly);
  const cv::Rect2d area(box.x - 16, box.y - 16, box.width + 32, box.height + 32);
  for (int k = d.integer(1, 3), b = 0; k > 0; --k) {
    if (auto ring = place_box(L, d, area, 8, 18, 6, 14, 4.5, 3.0)) {
      WallSpec w;
      w.name = "building_" + std::to_string(b++);
      w.texture = "facade" + std::to_string(d.integer(0, 2));
      w.height_m = d.uniform(6, 14);
      w.polyline = *ring;
      w.closed = true;
      L.add_wall(std::move(w));
    }
  }
  for (int k = d.integer(0, 2); k > 0; --k) {
    const std::size_t i = static_cast<std::size_t>(d.integer(0, static_cast<int>(n) - 1));
    const P a = poly[i], b = poly[(i + 1) % n];
    const P u = (b - a) / cv::norm(b - a), nn(-u.y, u.x);
    const double off = d.uniform(4, 8) * (d.chance(0.5) ? 1 : -1);
    const P p = a + nn * off - u * d.uniform(0, 4), q = b + nn * off + u * d.uniform(0, 4);
    if (!L.clear_of_route(p, q, gp.route_clearance_m + 1.0) || !L.segment_clear_of_solid(p, q, 1.0)) continue;
    L.add_wall(WallSpec{"fence_" + std::to_string(k), "fence", "fence", {p, q}, false, d.uniform(1.0, 1.6), 0.0});
  }
  place_trees(L, d, area, d.integer(8, 26), gp.route_clearance_m + 0.4);
  for (int k = d.integer(0, 3), b = 0; k > 0; --k)
    if (auto ring = place_box(L, d, cv::Rect2d(box.x - 4, box.y - 4, box.width + 8, box.height + 8), 1.0, 2.5, 0.5, 1.0,
                              gp.route_clearance_m, 1.0))
      L.add_wall(WallSpec{"bench_" + std::to_string(b++), d.chance(0.5) ? "fence" : "concrete", "obstacle", *ring, true,
                          d.uniform(0.45, 0.9), 0.0});
}

void build_outdoor(Layout& L, Draw& d, const std::vector<P>& poly, bool mixed, const GenerateParams& gp) {
  const std::size_t n = poly.size();
  std::size_t hall_side = n;
  const std::vector<bool> path_side = choose_path_sides(d, poly, mixed, hall_side);
  make_waypoints(L, poly, path_side);
  add_ground_regions(L, d, poly, path_side, hall_side);
  if (hall_side < n) add_hall(L, d, poly, hall_side, gp);
  add_outdoor_scenery(L, d, poly, gp);
}

void build_indoor(Layout& L, Draw& d, const std::vector<P>& poly, const GenerateParams& gp) {
  const std::size_t n = poly.size();
  make_waypoints(L, poly, std::vector<bool>(n, false));
  const cv::Rect2d box = bounding_box(poly);
  const double margin = d.uniform(2.6, 4.5);
  const cv::Rect2d hall(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin);
  const std::vector<P> outline = {{hall.x, hall.y}, {hall.x + hall.width, hall.y}, {hall.x + hall.width, hall.y + hall.height},
                                  {hall.x, hall.y + hall.height}};
  L.default_ground = "concrete";
  const std::string floor_texture = d.chance(0.65) ? "floor" : "floor_wood";
  L.regions.push_back(RegionSpec{"hall_floor", floor_texture, "floor", outline, {}, 0.0});
  const std::string wall_texture = d.pick(std::vector<std::string>{"indoor", "plaster", "brick", "brick_photo"});
  const double height = d.uniform(3.0, 6.0);
  L.add_wall(WallSpec{"hall_walls", wall_texture, "wall", outline, true, height, 0.0});
  L.notes.push_back("floor " + floor_texture + ", walls " + wall_texture);
  // corridors: walls either side of some sides (never the start side: the replay starts 1 m off it)
  int corridors = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const P a = poly[i], b = poly[(i + 1) % n];
    const double len = cv::norm(b - a);
    if (len < 9.0 || !d.chance(0.55)) continue;
    const double hw = std::max(gp.corridor_half_width_m, d.uniform(gp.corridor_half_width_m, gp.corridor_half_width_m + 0.6));
    const P u = (b - a) / len, nn(-u.y, u.x);
    const double t0 = 3.2, t1 = len - 3.2;
    bool ok = true;
    for (int s : {-1, 1}) {
      const P p = a + u * t0 + nn * (s * hw), q = a + u * t1 + nn * (s * hw);
      // clear of every other part of the route by the general clearance
      for (std::size_t k = 0; k + 1 < L.route.size(); ++k) {
        const P m = (L.route[k] + L.route[k + 1]) * 0.5;
        if (point_segment_m(m, a, b) > 0.01) {
          if (segment_segment_m(p, q, L.route[k], L.route[k + 1]) < gp.route_clearance_m) ok = false;
        }
      }
      if (!L.segment_clear_of_solid(p, q, 0.5)) ok = false;
    }
    if (!ok) continue;
    corridor(L, a, b, t0, t1, hw, d.chance(0.5) ? wall_texture : "plaster", d.uniform(2.2, height), "corridor_" + std::to_string(i));
    ++corridors;
  }
  L.notes.push_back(std::to_string(corridors) + " corridors");
  for (int k = d.integer(2, 6), b = 0; k > 0; --k)
    if (auto ring = place_box(L, d, hall, 0.4, 0.8, 0.4, 0.8, gp.route_clearance_m, 1.0))
      L.add_wall(WallSpec{"pillar_" + std::to_string(b++), d.chance(0.5) ? "brick" : "concrete", "obstacle", *ring, true, height, 0.0});
  for (int k = d.integer(0, 3), b = 0; k > 0; --k)
    if (auto ring = place_box(L, d, hall, 1.5, 3.5, 0.6, 1.5, gp.route_clearance_m, 1.0))
      L.add_wall(WallSpec{"counter_" + std::to_string(b++), "fence", "obstacle", *ring, true, d.uniform(0.8, 1.2), 0.0});
  // photographs on the walls (real textures: python3-skimage's colour photos)
  const std::vector<std::string> photos = {"poster_coffee", "poster_rocket", "poster_camera",
                                           "poster_motorcycle_left"};
  for (int k = d.integer(3, 7), b = 0; k > 0; --k) {
    const std::size_t side = static_cast<std::size_t>(d.integer(0, 3));
    const P a = outline[side], c = outline[(side + 1) % 4];
    const double len = cv::norm(c - a);
    const P u = (c - a) / len, inward(-u.y, u.x);  // the outline is counter-clockwise: inside is left
    const double w = d.uniform(1.0, 2.0), t = d.uniform(1.0, std::max(1.1, len - w - 1.0)), base = d.uniform(0.5, 1.2);
    WallSpec poster{"poster_" + std::to_string(b++), d.pick(photos), "wall", {a + u * t + inward * 0.04, a + u * (t + w) + inward * 0.04},
                    false, w * 0.75, base};
    L.add_wall(std::move(poster));
  }
}

/// Obstacles for the replays: static ones on the route's centre line (with room beside them)
/// and, sometimes, a person crossing it.
void place_obstacles(Layout& L, Draw& d) {
  std::vector<std::size_t> legs;
  for (std::size_t i = 1; i + 1 < L.route.size(); ++i)
    if (cv::norm(L.route[i + 1] - L.route[i]) >= 6.0) legs.push_back(i);
  int placed = 0;
  for (int attempt = 0; attempt < 12 && placed < 2 && !legs.empty(); ++attempt) {
    const std::size_t i = d.pick(legs);
    const P a = L.route[i], b = L.route[i + 1];
    const double len = cv::norm(b - a);
    const P u = (b - a) / len, nn(-u.y, u.x);
    const P at = a + u * d.uniform(2.5, len - 2.5) + nn * d.uniform(-0.3, 0.3);
    // room to pass: nothing solid within 3.5 m, no other obstacle within 8 m
    if (L.solid_distance(at) < 3.5) continue;
    bool far = true;
    for (const auto& o : L.obstacles) far = far && cv::norm(o.at - at) > 8.0;
    if (!far) continue;
    ObstacleSpec o;
    o.name = "route_obstacle_" + std::to_string(++placed);
    o.kind = d.pick(std::vector<std::string>{"box", "box", "person", "post"});
    o.texture = o.kind == "person" ? "fence" : "concrete";
    o.at = at;
    o.yaw_deg = d.uniform(0, 180);
    L.obstacles.push_back(std::move(o));
  }
  if (placed > 0 && d.chance(0.5) && !legs.empty()) {  // a person walking across a leg
    const std::size_t i = d.pick(legs);
    const P a = L.route[i], b = L.route[i + 1];
    const double len = cv::norm(b - a);
    const P u = (b - a) / len, nn(-u.y, u.x);
    const P c = a + u * (len * 0.5);
    const P from = c - nn * 3.5, to = c + nn * 3.5;
    bool free = L.segment_clear_of_solid(from, to, 1.0);
    for (const auto& o : L.obstacles) free = free && cv::norm(o.at - c) > 6.0;
    if (free) {
      ObstacleSpec w;
      w.name = "route_obstacle_walker";
      w.kind = "person";
      w.texture = "fence";
      w.at = from;
      w.path = {to};
      w.speed_mps = d.uniform(0.6, 1.2);
      w.start_s = d.uniform(0, 20);
      L.obstacles.push_back(std::move(w));
    }
  }
}

/// Local → world: rotation by `yaw` about the origin, then a shift.
struct Placement {
  double yaw = 0.0;
  P shift;
  P operator()(const P& p) const {
    return {p.x * std::cos(yaw) - p.y * std::sin(yaw) + shift.x, p.x * std::sin(yaw) + p.y * std::cos(yaw) + shift.y};
  }
};

std::string pt(const P& p) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << "[" << p.x << ", " << p.y << "]";
  return s.str();
}
std::string pts(const std::vector<P>& v, const Placement& T) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + pt(T(v[i]));
  return s + "]";
}
std::string num(double v, int digits = 2) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

Status check_generated_world(const World& world, const std::vector<cv::Point2d>& route, const std::vector<std::string>& leg_kinds,
                             double clearance_m) {
  if (route.size() < 4 || cv::norm(route.front() - route.back()) > 1e-6) return fail("the route is not a closed polyline");
  if (leg_kinds.size() + 1 != route.size()) return fail("one leg kind per route leg expected");
  for (const Wall& w : world.walls) {
    if (w.name.rfind("route_obstacle_", 0) == 0) continue;
    if (w.base_m >= 0.6) continue;  // lintels: the body passes under
    if (w.label == LabelClass::tree) {  // a tree collides as a trunk disc at its billboards' centre
      const P trunk = (w.from + w.to) * 0.5;
      const double d = point_route_m(trunk, route);
      if (d < clearance_m)
        return fail("tree '" + w.name + "' at (" + num(trunk.x) + ", " + num(trunk.y) + ") is " + num(d) + " m from the route (< " +
                    num(clearance_m) + " m)");
      continue;
    }
    const double d = segment_route_m(w.from, w.to, route);
    if (d < clearance_m)
      return fail("wall '" + w.name + "' is " + num(d) + " m from the route (< " + num(clearance_m) + " m)");
  }
  for (std::size_t i = 0; i < leg_kinds.size(); ++i) {
    if (leg_kinds[i] != "path") continue;
    const P a = route[i], b = route[i + 1];
    const double len = cv::norm(b - a);
    for (double t = 1.0; t <= len - 1.0; t += 0.5) {
      const P p = a + (b - a) * (t / len);
      if (world.ground_label_at(p.x, p.y) != LabelClass::path)
        return fail("path leg " + std::to_string(i) + " leaves the path at (" + num(p.x) + ", " + num(p.y) + "): ground is " +
                    to_string(world.ground_label_at(p.x, p.y)));
    }
  }
  return ok();
}

namespace {

// The lighting: a colour cast and level on every texture, and a sky (draws from `d`).
Light draw_lighting(Layout& L, Draw& d) {
  Light li;
  const int light = L.kind == "indoor" ? d.integer(0, 1) : d.integer(0, 3);
  const std::vector<std::string> light_names = L.kind == "indoor" ? std::vector<std::string>{"lamps", "daylight"}
                                                                   : std::vector<std::string>{"clear", "overcast", "evening", "hazy"};
  L.lighting = light_names[static_cast<std::size_t>(light)];
  if (L.lighting == "clear" || L.lighting == "daylight") { li.gain = d.uniform(0.95, 1.1); L.sky_zenith = colour(95, 140, 205); L.sky_horizon = colour(205, 220, 235); L.fog_m = d.uniform(250, 400); }
  else if (L.lighting == "overcast") { li.gain = d.uniform(0.75, 0.9); li.b = 1.04; L.sky_zenith = colour(170, 174, 182); L.sky_horizon = colour(206, 208, 212); L.fog_m = d.uniform(150, 250); }
  else if (L.lighting == "evening") { li.gain = d.uniform(0.7, 0.85); li.r = 1.12; li.b = 0.85; L.sky_zenith = colour(80, 100, 160); L.sky_horizon = colour(240, 180, 120); L.fog_m = d.uniform(200, 350); }
  else if (L.lighting == "hazy") { li.gain = d.uniform(0.9, 1.0); L.sky_zenith = colour(160, 180, 205); L.sky_horizon = colour(225, 228, 230); L.fog_m = d.uniform(80, 140); }
  else { li.gain = d.uniform(0.8, 0.95); li.r = 1.06; li.b = 0.92; L.sky_zenith = colour(120, 120, 120); L.sky_horizon = colour(170, 165, 160); L.fog_m = 0; }
  return li;
}

// The world file's text: the layout placed by `T`, the robot's start at `start`.
std::string world_yaml_text(const Layout& L, const Placement& T, const GenerateParams& gp, const std::string& name,
                            const P& start, double heading0_deg) {
  std::ostringstream w;
  w << "# Generated by `visnav sim generate --seed " << gp.seed << "` (" << L.kind << ", lighting " << L.lighting
    << "); route " << name << "_route.yaml. Keys: docs/sim.md.\n"
    << "world:\n  name: " << name << "\n  ground_resolution_m: 0.05\n  sky_zenith: " << L.sky_zenith
    << "\n  sky_horizon: " << L.sky_horizon << "\n  fog_distance_m: " << num(L.fog_m, 0) << "\n  start: [" << num(start.x) << ", "
    << num(start.y) << ", " << num(heading0_deg, 1) << "]\n  textures:\n";
  for (const auto& t : L.texture_lines) w << "    " << t << "\n";
  w << "  default_ground: {texture: " << L.default_ground << ", class: " << (L.kind == "indoor" ? "ground" : "grass") << "}\n";
  w << "  regions:\n";
  for (const auto& r : L.regions) {
    w << "    - {name: " << r.name << ", texture: " << r.texture << ", class: " << r.label;
    if (!r.polyline.empty()) w << ", width_m: " << num(r.width_m) << ", polyline: " << pts(r.polyline, T) << "}\n";
    else w << ", polygon: " << pts(r.polygon, T) << "}\n";
  }
  w << "  walls:\n";
  for (const auto& x : L.walls) {
    w << "    - {name: " << x.name << ", texture: " << x.texture << ", class: " << x.label << ", height_m: " << num(x.height_m);
    if (x.base_m > 0) w << ", base_m: " << num(x.base_m);
    if (x.closed) w << ", closed: true";
    w << ", polyline: " << pts(x.polyline, T) << "}\n";
  }
  if (!L.trees.empty()) {
    w << "  trees:\n";
    for (const auto& t : L.trees)
      w << "    - {at: " << pt(T(t.at)) << ", height_m: " << num(t.height_m) << ", width_m: " << num(t.width_m) << ", yaw_deg: " << num(t.yaw_deg, 0)
        << ", texture: " << t.texture << "}\n";
  }
  return w.str();
}

}  // namespace

Result<GeneratedWorld> generate_world(const GenerateParams& gp) {
  if (gp.kind != "any" && gp.kind != "indoor" && gp.kind != "outdoor" && gp.kind != "mixed")
    return fail("kind '" + gp.kind + "': expected any, indoor, outdoor or mixed");
  if (gp.obstacles != "auto" && gp.obstacles != "yes" && gp.obstacles != "no")
    return fail("obstacles '" + gp.obstacles + "': expected auto, yes or no");
  if (gp.seed < 0) return fail("seed " + std::to_string(gp.seed) + ": expected a non-negative integer");
  Draw d(static_cast<std::uint64_t>(gp.seed));
  Layout L;
  if (gp.kind == "any") {
    const int k = d.integer(0, 3);
    L.kind = k == 0 ? "indoor" : k == 3 ? "mixed" : "outdoor";
  } else {
    L.kind = gp.kind;
  }
  const Light li = draw_lighting(L, d);
  add_textures(L, d, li);
  const std::vector<P> poly = route_polygon(d, L.kind);
  if (L.kind == "indoor") build_indoor(L, d, poly, gp);
  else build_outdoor(L, d, poly, L.kind == "mixed", gp);
  const bool want_obstacles = gp.obstacles == "yes" || (gp.obstacles == "auto" && gp.seed % 3 == 0);
  if (want_obstacles) place_obstacles(L, d);

  Placement T;
  T.yaw = d.uniform(-kPi, kPi);
  T.shift = P(std::round(d.uniform(-50, 50)), std::round(d.uniform(-50, 50)));
  const double heading0_deg = std::remainder(T.yaw, 2 * kPi) * 180.0 / kPi;  // the first side runs along local +x

  GeneratedWorld g;
  {
    std::ostringstream s;
    s << "gen_" << std::setw(4) << std::setfill('0') << gp.seed;
    g.name = s.str();
  }
  g.kind = L.kind;
  const P start = T(L.waypoints.front().at);
  g.world_yaml = world_yaml_text(L, T, gp, g.name, start, heading0_deg);

  std::ostringstream r;
  r << "# Closed teach route of " << g.name << ".yaml (`visnav sim generate --seed " << gp.seed
    << "`): feature legs at corners, squares and indoors, path legs on the paths.\nroute:\n  name: " << g.name << "\n  world: " << g.name
    << ".yaml\n  start: [" << num(start.x) << ", " << num(start.y) << ", " << num(heading0_deg, 1) << "]\n  closed: true\n"
    << "  pursuit: {lookahead_m: 1.2, speed_mps: 0.6, min_speed_mps: 0.2, max_angular_radps: 0.8, command_rate_hz: 5, "
       "angular_step_radps: 0.05, goal_tolerance_m: 0.3}\n  waypoints:\n";
  std::string previous;
  for (const auto& wp : L.waypoints) {
    r << "    - {at: " << pt(T(wp.at));
    if (wp.kind != previous) r << ", kind: " << wp.kind;
    r << "}\n";
    previous = wp.kind;
    (wp.kind == "path" ? g.path_legs : g.feature_legs)++;
  }
  g.route_yaml = r.str();

  if (!L.obstacles.empty()) {
    std::ostringstream o;
    o << "# Obstacles on the route of " << g.name << " for the replays (`visnav experiment --obstacles`), from `visnav sim "
      << "generate --seed " << gp.seed << "`; textures are the world's.\nobstacles:\n";
    for (const auto& x : L.obstacles) {
      o << "  - {name: " << x.name << ", kind: " << x.kind << ", at: " << pt(T(x.at)) << ", yaw_deg: " << num(x.yaw_deg + T.yaw * 180 / kPi, 0)
        << ", texture: " << x.texture;
      if (!x.path.empty())
        o << ", path: " << pts(x.path, T) << ", speed_mps: " << num(x.speed_mps) << ", start_s: " << num(x.start_s, 1)
          << ", motion: back_and_forth";
      o << "}\n";
    }
    g.obstacles_yaml = o.str();
    g.obstacles = static_cast<int>(L.obstacles.size());
  }

  // the check the header promises, on the parsed files
  VISNAV_ASSIGN(auto world, parse_world(g.world_yaml, g.name + ".yaml", "."));
  VISNAV_ASSIGN(const Route route, parse_route(g.route_yaml, g.name + "_route.yaml"));
  std::vector<P> closed;
  std::vector<std::string> kinds;
  for (const auto& wp : route.waypoints) { closed.push_back(wp.position_m); kinds.push_back(wp.kind); }
  closed.push_back(closed.front());
  g.route_length_m = route.waypoint_length_m();
  if (auto st = check_generated_world(*world, closed, kinds, std::min(gp.route_clearance_m, gp.corridor_half_width_m) - 0.05); !st)
    return fail("generated world " + g.name + " fails its own check (a generator bug): " + st.error().message);
  std::ostringstream summary;
  summary << g.name << ": " << L.kind << ", " << num(g.route_length_m, 1) << " m route (" << g.feature_legs << " feature + "
          << g.path_legs << " path legs), lighting " << L.lighting;
  for (const auto& n : L.notes) summary << ", " << n;
  summary << ", " << L.walls.size() << " walls, " << L.trees.size() << " trees";
  if (g.obstacles > 0) summary << ", " << g.obstacles << " obstacles";
  g.summary = summary.str();
  return g;
}

Result<std::vector<std::string>> write_generated_world(const GeneratedWorld& g, const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail("cannot create folder '" + dir + "': " + ec.message());
  std::vector<std::string> written;
  auto put = [&](const std::string& file, const std::string& text) -> Status {
    const std::string path = (fs::path(dir) / file).string();
    const std::string tmp = path + ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary);
      out << text;
      if (!out) return fail("cannot write '" + tmp + "'");
    }
    fs::rename(tmp, path, ec);
    if (ec) return fail("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
    written.push_back(path);
    return ok();
  };
  VISNAV_TRY(put(g.name + ".yaml", g.world_yaml));
  VISNAV_TRY(put(g.name + "_route.yaml", g.route_yaml));
  if (!g.obstacles_yaml.empty()) VISNAV_TRY(put(g.name + "_obstacles.yaml", g.obstacles_yaml));
  const std::string world_path = (fs::path(dir) / (g.name + ".yaml")).string();
  VISNAV_ASSIGN(auto world, g.obstacles_yaml.empty()
                                ? load_world(world_path)
                                : load_world_with_obstacles(world_path, (fs::path(dir) / (g.name + "_obstacles.yaml")).string()));
  VISNAV_ASSIGN(const Route route, load_route((fs::path(dir) / (g.name + "_route.yaml")).string()));
  const std::string top = (fs::path(dir) / (g.name + "_top.png")).string();
  if (!cv::imwrite(top, render_topview(*world, &route, 0.0))) return fail("cannot write '" + top + "'");
  written.push_back(top);
  return written;
}

}  // namespace visnav::sim
