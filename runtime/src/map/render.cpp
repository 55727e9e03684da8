// Dead-reckoned map layout and drawing.
#include "map/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <functional>

#include <opencv2/imgproc.hpp>

namespace visnav::map_detail {

namespace {

cv::Point2d direction(double azimuth_rad) { return {std::cos(azimuth_rad), std::sin(azimuth_rad)}; }

double nice_step(double raw) {
  if (!(raw > 0.0)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) if (m * p >= raw) return m * p;
  return 10.0 * p;
}

std::string metres_text(double m) {
  char buf[32];
  if (m >= 1000.0) std::snprintf(buf, sizeof buf, "%g km", m / 1000.0);
  else std::snprintf(buf, sizeof buf, "%g m", m);
  return buf;
}

void dashed_line(cv::Mat& img, cv::Point2d a, cv::Point2d b, const cv::Scalar& colour) {
  const double len = cv::norm(b - a);
  const int dashes = std::max(1, static_cast<int>(len / 8.0));
  for (int i = 0; i < dashes; i += 2) {
    const cv::Point2d p0 = a + (b - a) * (static_cast<double>(i) / dashes);
    const cv::Point2d p1 = a + (b - a) * (static_cast<double>(i + 1) / dashes);
    cv::line(img, cv::Point(cvRound(p0.x), cvRound(p0.y)), cv::Point(cvRound(p1.x), cvRound(p1.y)), colour, 1, cv::LINE_AA);
  }
}

}  // namespace

cv::Scalar kind_colour(const std::string& kind) {
  if (kind.rfind("feature", 0) == 0) return {40, 40, 220};       // red (BGR)
  if (kind.rfind("path", 0) == 0) return {200, 90, 20};          // blue
  if (kind.rfind("visual_memory", 0) == 0) return {60, 160, 40};  // green
  static const cv::Scalar palette[] = {{0, 140, 255}, {180, 60, 160}, {150, 150, 0}, {30, 100, 140}, {120, 120, 120}};
  const std::size_t h = std::hash<std::string>{}(kind);
  return palette[h % (sizeof palette / sizeof palette[0])];
}

MapLayout layout_map(const MapStore& map) {
  MapLayout layout;
  const auto& nodes = map.nodes();
  const auto& edges = map.edges();
  std::deque<std::string> queue;
  for (const auto& n : nodes) {
    if (n.position_hint) {
      layout.node_xy_m[n.id] = {n.position_hint->x_m, n.position_hint->y_m};
      queue.push_back(n.id);
    }
  }
  // Forward dead reckoning (the order the route was taught) from every placed node; a node only
  // reachable against an edge direction is placed backwards from the edge's end, one at a time,
  // so forward integration always wins where it is possible.
  auto spread_forward = [&]() {
    while (!queue.empty()) {
      const std::string u = queue.front();
      queue.pop_front();
      const cv::Point2d pu = layout.node_xy_m.at(u);
      for (const auto* e : map.outgoing(u)) {
        if (layout.node_xy_m.count(e->to) == 0) {
          layout.node_xy_m[e->to] = pu + direction(e->azimuth_rad) * e->length_m;
          queue.push_back(e->to);
        }
      }
    }
  };
  auto place_one_backwards = [&]() {
    for (const auto& e : edges) {
      if (layout.node_xy_m.count(e.from) == 0 && layout.node_xy_m.count(e.to) != 0) {
        layout.node_xy_m[e.from] = layout.node_xy_m.at(e.to) - direction(e.azimuth_rad) * e.length_m;
        queue.push_back(e.from);
        return true;
      }
    }
    return false;
  };
  auto spread = [&]() {
    do spread_forward();
    while (place_one_backwards());
  };
  spread();
  for (const auto& n : nodes) {
    if (layout.node_xy_m.count(n.id) != 0) continue;
    cv::Point2d origin{0.0, 0.0};
    if (!layout.node_xy_m.empty()) {
      double max_x = -1e300, min_x = 1e300, min_y = 1e300;
      for (const auto& [id, p] : layout.node_xy_m) {
        max_x = std::max(max_x, p.x);
        min_x = std::min(min_x, p.x);
        min_y = std::min(min_y, p.y);
      }
      origin = {max_x + std::max(5.0, 0.2 * (max_x - min_x)), min_y};
    }
    layout.node_xy_m[n.id] = origin;
    queue.push_back(n.id);
    spread();
  }
  for (const auto& e : edges) {
    MapLayout::EdgeSegment s;
    s.start_m = layout.node_xy_m.at(e.from);
    s.to_node_m = layout.node_xy_m.at(e.to);
    const auto* from = map.find_node(e.from);
    const auto* to = map.find_node(e.to);
    if (from->position_hint && to->position_hint) s.end_m = s.to_node_m;  // recorded odometry wins
    else s.end_m = s.start_m + direction(e.azimuth_rad) * e.length_m;
    layout.edges.push_back(s);
  }
  return layout;
}

namespace {

/// The picture's geometry: odometry-frame metres to pixels, and the bands around the drawing.
struct Canvas {
  int width_px = 0, height_px = 0;
  int title_h = 40, margin = 70, legend_h = 0;
  double draw_w = 0.0;
  double scale = 1.0;       ///< px per metre
  double cx = 0.0, cy = 0.0;  ///< metres at the drawing's centre
  double ox = 0.0, oy = 0.0;  ///< that centre in pixels
  /// Odometry frame (x right, y up) to image (v down).
  [[nodiscard]] cv::Point2d px(cv::Point2d p) const { return {ox + (p.x - cx) * scale, oy - (p.y - cy) * scale}; }
  static cv::Point ipt(cv::Point2d p) { return {cvRound(p.x), cvRound(p.y)}; }
};

/// Fits the layout's extent into `width_px` (the height follows, at most twice the width).
Canvas fit_canvas(const MapLayout& layout, int width_px, std::size_t legend_rows) {
  double min_x = 0, max_x = 1, min_y = 0, max_y = 1;
  bool first = true;
  auto extend = [&](cv::Point2d p) {
    if (first) { min_x = max_x = p.x; min_y = max_y = p.y; first = false; return; }
    min_x = std::min(min_x, p.x); max_x = std::max(max_x, p.x);
    min_y = std::min(min_y, p.y); max_y = std::max(max_y, p.y);
  };
  for (const auto& [id, p] : layout.node_xy_m) extend(p);
  for (const auto& s : layout.edges) extend(s.end_m);
  Canvas c;
  const double extent = std::max({max_x - min_x, max_y - min_y, 1.0});
  c.cx = 0.5 * (min_x + max_x);
  c.cy = 0.5 * (min_y + max_y);
  const double span_x = std::max(max_x - min_x, 0.05 * extent), span_y = std::max(max_y - min_y, 0.05 * extent);
  c.width_px = width_px;
  c.legend_h = 30 + 24 * static_cast<int>(std::max<std::size_t>(1, legend_rows));
  c.draw_w = width_px - 2.0 * c.margin;
  c.scale = c.draw_w / span_x;
  const double max_draw_h = 2.0 * width_px;
  if (span_y * c.scale > max_draw_h) c.scale = max_draw_h / span_y;
  const int draw_h = static_cast<int>(std::ceil(span_y * c.scale));
  c.height_px = c.title_h + draw_h + 2 * c.margin + c.legend_h;
  c.ox = width_px / 2.0;
  c.oy = c.title_h + c.margin + draw_h / 2.0;
  return c;
}

void draw_grid(cv::Mat& img, const Canvas& c) {
  const double grid_m = nice_step(100.0 / c.scale);
  const cv::Scalar grey(235, 235, 235);
  for (double gx = std::floor((c.cx - c.ox / c.scale) / grid_m) * grid_m; c.px({gx, 0}).x < c.width_px; gx += grid_m) {
    const double x = c.px({gx, 0}).x;
    cv::line(img, Canvas::ipt({x, static_cast<double>(c.title_h)}), Canvas::ipt({x, static_cast<double>(c.height_px - c.legend_h)}),
             grey, 1);
  }
  for (double gy = std::floor((c.cy - (c.height_px - c.oy) / c.scale) / grid_m) * grid_m; c.px({0, gy}).y > c.title_h; gy += grid_m) {
    const double y = c.px({0, gy}).y;
    if (y > c.height_px - c.legend_h) continue;
    cv::line(img, Canvas::ipt({0.0, y}), Canvas::ipt({static_cast<double>(c.width_px), y}), grey, 1);
  }
}

/// Edges as arrows in their kind's colour, loop-closure drift dashed, marked positions ticked.
void draw_edges(cv::Mat& img, const Canvas& c, const MapStore& map, const MapLayout& layout) {
  const auto& edges = map.edges();
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const auto& s = layout.edges[i];
    const cv::Point2d a = c.px(s.start_m), b = c.px(s.end_m), t = c.px(s.to_node_m);
    const double len_px = cv::norm(b - a);
    const cv::Scalar colour = kind_colour(edges[i].kind);
    if (len_px < 1.0) {
      cv::circle(img, Canvas::ipt(a), 10, colour, 2, cv::LINE_AA);  // zero-length or loop edge
    } else {
      cv::arrowedLine(img, Canvas::ipt(a), Canvas::ipt(b), colour, 3, cv::LINE_AA, 0, std::min(0.3, 14.0 / len_px));
    }
    if (cv::norm(b - t) > 2.0) dashed_line(img, b, t, cv::Scalar(150, 150, 150));  // odometric drift at loop closure
    // Positions along the edge a primitive marks (statistics "mark.<name>_m", metres from the
    // start; e.g. a visual_memory edge's reference images): a tick across the arrow.
    if (len_px < 1.0 || !(edges[i].length_m > 0.0)) continue;
    const cv::Point2d dir = (b - a) * (1.0 / len_px), across(-dir.y, dir.x);
    for (const auto& [key, d] : edges[i].statistics) {
      if (key.rfind("mark.", 0) != 0 || key.size() < 8 || key.compare(key.size() - 2, 2, "_m") != 0) continue;
      if (!(d >= 0.0 && d <= edges[i].length_m)) continue;
      const cv::Point2d m = a + (b - a) * (d / edges[i].length_m);
      cv::line(img, Canvas::ipt(m - 6.0 * across), Canvas::ipt(m + 6.0 * across), colour * 0.5, 2, cv::LINE_AA);
    }
  }
}

void draw_nodes(cv::Mat& img, const Canvas& c, const MapStore& map, const MapLayout& layout) {
  for (const auto& n : map.nodes()) {
    const cv::Point p = Canvas::ipt(c.px(layout.node_xy_m.at(n.id)));
    cv::circle(img, p, 6, cv::Scalar(30, 30, 30), cv::FILLED, cv::LINE_AA);
    cv::circle(img, p, 3, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA);
    const std::string label = n.name.empty() ? n.id : n.name;
    cv::putText(img, label, p + cv::Point(9, -8), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
    cv::putText(img, label, p + cv::Point(9, -8), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(20, 20, 20), 1, cv::LINE_AA);
  }
}

/// Title, scale bar and the legend of edge kinds.
void draw_furniture(cv::Mat& img, const Canvas& c, const MapStore& map, const MapStats& stats) {
  char title[256];
  std::snprintf(title, sizeof title, "map '%s': %zu nodes, %zu edges, %.1f m", map.name().c_str(), stats.nodes,
                stats.total.edges, stats.total.length_m);
  cv::putText(img, title, {15, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const double bar_m = nice_step(0.2 * c.draw_w / c.scale);
  const int bar_px = cvRound(bar_m * c.scale);
  const int bar_y = c.height_px - c.legend_h - 20;
  cv::line(img, {20, bar_y}, {20 + bar_px, bar_y}, cv::Scalar(0, 0, 0), 2);
  cv::line(img, {20, bar_y - 5}, {20, bar_y + 5}, cv::Scalar(0, 0, 0), 2);
  cv::line(img, {20 + bar_px, bar_y - 5}, {20 + bar_px, bar_y + 5}, cv::Scalar(0, 0, 0), 2);
  cv::putText(img, metres_text(bar_m), {25 + bar_px, bar_y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  int ly = c.height_px - c.legend_h + 20;
  cv::line(img, {0, c.height_px - c.legend_h}, {c.width_px, c.height_px - c.legend_h}, cv::Scalar(200, 200, 200), 1);
  if (stats.per_kind.empty())
    cv::putText(img, "(no edges)", {20, ly + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  for (const auto& [kind, k] : stats.per_kind) {
    cv::line(img, {20, ly}, {60, ly}, kind_colour(kind), 4, cv::LINE_AA);
    char text[256];
    std::snprintf(text, sizeof text, "%s: %zu edges, %.1f m, %.0f B/m", kind.c_str(), k.edges, k.length_m, k.bytes_per_m());
    cv::putText(img, text, {70, ly + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    ly += 24;
  }
}

}  // namespace

Result<cv::Mat> render_map(const MapStore& map, int width_px) {
  if (width_px < 200 || width_px > 20000)
    return fail(ErrorCode::out_of_range, "render width must be between 200 and 20000 px, got " + std::to_string(width_px));
  const MapLayout layout = layout_map(map);
  const MapStats stats = map.stats();
  const Canvas canvas = fit_canvas(layout, width_px, stats.per_kind.size());
  cv::Mat img(canvas.height_px, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  draw_grid(img, canvas);
  draw_edges(img, canvas, map, layout);
  draw_nodes(img, canvas, map, layout);
  draw_furniture(img, canvas, map, stats);
  return img;
}

}  // namespace visnav::map_detail
