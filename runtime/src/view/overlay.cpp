#include "view/overlay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace visnav::view {
namespace {

std::string num(double v) {
  if (!std::isfinite(v)) return "0";
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string stamp(double t_s) {
  const std::uint64_t ns = t_s <= 0.0 ? 0 : static_cast<std::uint64_t>(std::llround(t_s * 1e9));
  return "{\"sec\":" + std::to_string(ns / 1000000000ULL) + ",\"nsec\":" + std::to_string(ns % 1000000000ULL) + "}";
}

struct Rgba {
  double r, g, b, a;
  [[nodiscard]] std::string json() const {
    return "{\"r\":" + num(r) + ",\"g\":" + num(g) + ",\"b\":" + num(b) + ",\"a\":" + num(a) + "}";
  }
  [[nodiscard]] cv::Scalar bgr() const { return {b * 255.0, g * 255.0, r * 255.0}; }
};
constexpr Rgba kInlier{0.1, 0.9, 0.1, 1.0};
constexpr Rgba kOutlier{0.9, 0.1, 0.1, 1.0};
constexpr Rgba kMatchLine{1.0, 0.85, 0.1, 0.8};
constexpr Rgba kHistogram{1.0, 1.0, 1.0, 0.9};
constexpr Rgba kOffset{1.0, 0.1, 1.0, 1.0};
constexpr Rgba kPathOutline{0.1, 0.9, 0.1, 1.0};
constexpr Rgba kPathMiddle{0.1, 0.9, 0.9, 1.0};

// PointsAnnotation.type of foxglove.ImageAnnotations.
enum PointsType { kPoints = 1, kLineLoop = 2, kLineStrip = 3, kLineList = 4 };

/// The largest outer contour of the mask, simplified (2 px), or nothing.
std::vector<cv::Point> path_outline(const cv::Mat& mask) {
  if (mask.empty() || mask.type() != CV_8UC1) return {};
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  if (contours.empty()) return {};
  const auto largest = std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
    return cv::contourArea(a) < cv::contourArea(b);
  });
  std::vector<cv::Point> simple;
  cv::approxPolyDP(*largest, simple, 2.0, true);
  return simple;
}

/// Histogram bars along the bottom edge: (bottom, top) pairs, bar height up to a quarter of the image.
std::vector<std::pair<cv::Point2f, cv::Point2f>> histogram_bars(const OverlayCopy& o, cv::Size size) {
  std::vector<std::pair<cv::Point2f, cv::Point2f>> bars;
  if (o.histogram.empty() || o.histogram_bin_px <= 0.0) return bars;
  const int peak = *std::max_element(o.histogram.begin(), o.histogram.end());
  if (peak <= 0) return bars;
  const double half = static_cast<double>(o.histogram.size() / 2);
  const float bottom = static_cast<float>(size.height - 1);
  for (std::size_t i = 0; i < o.histogram.size(); ++i) {
    if (o.histogram[i] <= 0) continue;
    const auto u = static_cast<float>(size.width / 2.0 + (static_cast<double>(i) - half) * o.histogram_bin_px);
    if (u < 0.0F || u >= static_cast<float>(size.width)) continue;
    const auto h = static_cast<float>(size.height / 4.0 * o.histogram[i] / peak);
    bars.emplace_back(cv::Point2f(u, bottom), cv::Point2f(u, bottom - h));
  }
  return bars;
}

std::string points_json(const std::string& stamp_json, int type, const std::vector<cv::Point2f>& pts, const Rgba& color,
                        double thickness, const std::vector<Rgba>* colors = nullptr) {
  std::string p;
  for (const auto& q : pts) {
    if (!p.empty()) p += ',';
    p += "{\"x\":";
    p += num(q.x);
    p += ",\"y\":";
    p += num(q.y);
    p += '}';
  }
  std::string cs;
  if (colors != nullptr)
    for (const auto& c : *colors) {
      if (!cs.empty()) cs += ',';
      cs += c.json();
    }
  return "{\"timestamp\":" + stamp_json + ",\"type\":" + std::to_string(type) + ",\"points\":[" + p +
         "],\"outline_color\":" + color.json() + ",\"outline_colors\":[" + cs + "],\"fill_color\":" + color.json() +
         ",\"thickness\":" + num(thickness) + "}";
}

}  // namespace

void OverlayCopy::copy_from(const NavOverlay& o) {
  matched_px.assign(o.matched_px.begin(), o.matched_px.end());
  reference_px.assign(o.reference_px.begin(), o.reference_px.end());
  inlier.assign(o.inlier.begin(), o.inlier.end());
  histogram.assign(o.histogram.begin(), o.histogram.end());
  histogram_bin_px = o.histogram_bin_px;
  offset_px = o.offset_px;
  if (o.path_mask.empty()) path_mask.release();
  else o.path_mask.copyTo(path_mask);
  path_middle_px.assign(o.path_middle_px.begin(), o.path_middle_px.end());
  valid = true;
}

std::string annotations_json(const OverlayCopy& o, cv::Size size, double t_s) {
  std::string points, texts;
  const std::string ts = stamp(t_s);
  auto add = [&](const std::string& item) {
    if (!points.empty()) points += ',';
    points += item;
  };
  if (o.valid) {
    if (!o.matched_px.empty()) {
      std::vector<Rgba> colors;
      colors.reserve(o.matched_px.size());
      for (std::size_t i = 0; i < o.matched_px.size(); ++i)
        colors.push_back(i < o.inlier.size() && o.inlier[i] != 0 ? kInlier : kOutlier);
      add(points_json(ts, kPoints, o.matched_px, kInlier, 4.0, &colors));
    }
    if (o.reference_px.size() == o.matched_px.size() && !o.matched_px.empty()) {
      std::vector<cv::Point2f> segments;
      segments.reserve(2 * o.matched_px.size());
      for (std::size_t i = 0; i < o.matched_px.size(); ++i) {
        segments.push_back(o.reference_px[i]);
        segments.push_back(o.matched_px[i]);
      }
      add(points_json(ts, kLineList, segments, kMatchLine, 1.0));
    }
    const auto bars = histogram_bars(o, size);
    if (!bars.empty()) {
      std::vector<cv::Point2f> segments;
      for (const auto& [a, b] : bars) {
        segments.push_back(a);
        segments.push_back(b);
      }
      add(points_json(ts, kLineList, segments, kHistogram, std::max(1.0, o.histogram_bin_px * 0.6)));
    }
    if (!o.histogram.empty() || !o.path_middle_px.empty()) {
      const auto u = static_cast<float>(size.width / 2.0 + o.offset_px);
      add(points_json(ts, kLineStrip, {cv::Point2f(u, 0.0F), cv::Point2f(u, static_cast<float>(size.height - 1))}, kOffset, 2.0));
    }
    const auto outline = path_outline(o.path_mask);
    if (!outline.empty()) {
      std::vector<cv::Point2f> pts(outline.begin(), outline.end());
      add(points_json(ts, kLineLoop, pts, kPathOutline, 2.0));
    }
    if (!o.path_middle_px.empty()) add(points_json(ts, kLineStrip, o.path_middle_px, kPathMiddle, 2.0));
    int inliers = 0;
    for (auto v : o.inlier) inliers += v != 0 ? 1 : 0;
    const std::string label = o.path_mask.empty() && o.path_middle_px.empty()
                                  ? "matches " + std::to_string(o.matched_px.size()) + ", inliers " + std::to_string(inliers) +
                                        ", offset " + num(o.offset_px) + " px"
                                  : "path offset " + num(o.offset_px) + " px";
    texts = "{\"timestamp\":" + ts + ",\"position\":{\"x\":8,\"y\":20},\"text\":\"" + label +
            "\",\"font_size\":14,\"text_color\":{\"r\":1,\"g\":1,\"b\":1,\"a\":1},\"background_color\":{\"r\":0,\"g\":0,\"b\":0,\"a\":0.6}}";
  }
  return "{\"circles\":[],\"points\":[" + points + "],\"texts\":[" + texts + "]}";
}

void draw_overlay(cv::Mat& bgr, const OverlayCopy& o) {
  if (!o.valid || bgr.empty() || bgr.type() != CV_8UC3) return;
  if (!o.path_mask.empty() && o.path_mask.size() == bgr.size() && o.path_mask.type() == CV_8UC1) {
    cv::Mat tinted = bgr.clone();
    tinted.setTo(kPathOutline.bgr(), o.path_mask);
    cv::addWeighted(bgr, 0.6, tinted, 0.4, 0.0, bgr);
    const auto outline = path_outline(o.path_mask);
    if (!outline.empty()) cv::polylines(bgr, std::vector<std::vector<cv::Point>>{outline}, true, kPathOutline.bgr(), 2);
  }
  for (std::size_t i = 1; i < o.path_middle_px.size(); ++i)
    cv::line(bgr, o.path_middle_px[i - 1], o.path_middle_px[i], kPathMiddle.bgr(), 2);
  const bool lines = o.reference_px.size() == o.matched_px.size();
  for (std::size_t i = 0; i < o.matched_px.size(); ++i) {
    const bool in = i < o.inlier.size() && o.inlier[i] != 0;
    if (lines) cv::line(bgr, o.reference_px[i], o.matched_px[i], kMatchLine.bgr(), 1);
    cv::circle(bgr, o.matched_px[i], 3, (in ? kInlier : kOutlier).bgr(), -1);
  }
  const double bar_w = std::max(1.0, o.histogram_bin_px * 0.6);
  for (const auto& [a, b] : histogram_bars(o, bgr.size()))
    cv::line(bgr, a, b, kHistogram.bgr(), static_cast<int>(std::lround(bar_w)));
  if (!o.histogram.empty() || !o.path_middle_px.empty()) {
    const int u = static_cast<int>(std::lround(bgr.cols / 2.0 + o.offset_px));
    cv::line(bgr, {u, 0}, {u, bgr.rows - 1}, kOffset.bgr(), 2);
  }
}

}  // namespace visnav::view
