#include "visnav/ipt_obstacles/profiles.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace visnav::ipt {

Status ProfileParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<ProfileParams>& ProfileParams::schema() {
  using P = ProfileParams;
  static const auto s =
      ParamSchema<P>{}
          .field("sigma_px", &P::sigma_px, "derivative-of-Gaussian sigma along the rows").range(0.3, 10.0)
          .field("high_threshold", &P::high_threshold, "|g| of a strong edge pixel (grey levels of a step)")
          .range(1.0, 255.0)
          .field("low_ratio", &P::low_ratio, "low hysteresis threshold as a share of the high one").range(0.05, 1.0)
          .field("window_width_px", &P::window_width_px, "width of the window around an obstacle feature").range(1, 101)
          .field("window_height_px", &P::window_height_px, "height of that window").range(1, 201)
          .field("max_gap_rows", &P::max_gap_rows, "missing edge rows bridged while tracing down").range(0, 20)
          .field("ground_reach_px", &P::ground_reach_px, "a ground feature this close stops a trace").range(0.0, 20.0)
          .field("guard_band_px", &P::guard_band_px, "contact points this close below the horizon are dropped")
          .range(0.0, 1000.0)
          .field("min_vertical_run_px", &P::min_vertical_run_px,
                 "edge pixels must lie in vertical runs this long (morphological opening; 1 = off)")
          .range(1, 101)
          .field("max_range_m", &P::max_range_m, "contact points farther than this are dropped").range(0.1, 1000.0)
          .field("min_supporting_features", &P::min_supporting_features,
                 "obstacle features whose traces must end near a contact (1 = off)")
          .range(1, 100)
          .field("support_radius_px", &P::support_radius_px, "radius of that support").range(0.0, 50.0)
          .field("foot_radius_px", &P::foot_radius_px,
                 "obstacle features this many columns from a contact bound its range (0 = off)")
          .range(0.0, 100.0)
          .field("span_max_m", &P::span_max_m, "neighbouring contacts this close may bound one obstacle (0 = off)")
          .range(0.0, 20.0)
          .field("span_step_m", &P::span_step_m, "spacing of the points filled between them").range(0.01, 5.0)
          .field("span_min_obstacle_share", &P::span_min_obstacle_share,
                 "OBSTACLE share of the labelled features between them that fills the span")
          .range(0.0, 1.0);
  return s;
}

void reduced_canny(const cv::Mat& grey, const ProfileParams& params, cv::Mat& edges, EdgeScratch& scratch) {
  CV_Assert(grey.type() == CV_8UC1);
  // d/du of a Gaussian, scaled so that a step of height A gives a peak |g| = A.
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * params.sigma_px)));
  cv::Mat kernel(1, 2 * radius + 1, CV_32F);
  double positive = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    const double k = -i * std::exp(-0.5 * i * i / (params.sigma_px * params.sigma_px));
    kernel.at<float>(0, i + radius) = static_cast<float>(k);
    if (k > 0) positive += k;
  }
  kernel /= positive;
  cv::filter2D(grey, scratch.gradient, CV_32F, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
  scratch.gradient = cv::abs(scratch.gradient);
  const double low = params.low_ratio * params.high_threshold;
  cv::compare(scratch.gradient, low, edges, cv::CMP_GT);
  cv::compare(scratch.gradient, params.high_threshold, scratch.strong, cv::CMP_GT);
  // Hysteresis as connected components: keep the weak components that hold a strong pixel.
  const int n = cv::connectedComponents(edges, scratch.labels, 8, CV_32S);
  std::vector<std::uint8_t> keep(static_cast<std::size_t>(n), 0);
  for (int r = 0; r < edges.rows; ++r) {
    const auto* s = scratch.strong.ptr<std::uint8_t>(r);
    const auto* l = scratch.labels.ptr<int>(r);
    for (int c = 0; c < edges.cols; ++c)
      if (s[c] != 0) keep[static_cast<std::size_t>(l[c])] = 1;
  }
  for (int r = 0; r < edges.rows; ++r) {
    auto* e = edges.ptr<std::uint8_t>(r);
    const auto* l = scratch.labels.ptr<int>(r);
    for (int c = 0; c < edges.cols; ++c) e[c] = (e[c] != 0 && keep[static_cast<std::size_t>(l[c])] != 0) ? 255 : 0;
  }
  if (params.min_vertical_run_px > 1)
    cv::morphologyEx(edges, edges, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_RECT, cv::Size(1, params.min_vertical_run_px)));
}

namespace {

bool is_edge(const cv::Mat& edges, int u, int v) {
  return u >= 0 && v >= 0 && u < edges.cols && v < edges.rows && edges.at<std::uint8_t>(v, u) != 0;
}

/// Follows an edge down from (u, v); returns the last pixel (spec §4.2 step rule).
cv::Point trace_down(const cv::Mat& edges, const cv::Mat& ground_stop, cv::Point p, int max_gap_rows) {
  while (true) {
    if (ground_stop.at<std::uint8_t>(p.y, p.x) != 0) return p;
    bool moved = false;
    for (int gap = 0; gap <= max_gap_rows && !moved; ++gap) {
      const int v = p.y + 1 + gap;
      if (v >= edges.rows) break;
      for (const int du : {0, -1, 1}) {
        if (is_edge(edges, p.x + du, v)) {
          p = {p.x + du, v};
          moved = true;
          break;
        }
      }
    }
    if (!moved) return p;
  }
}

}  // namespace

std::vector<ContactPoint> contact_points(const cv::Mat& edges, std::span<const ClassifiedFeature> features,
                                         const IptCamera& camera, const Pose2D& robot, const ProfileParams& params) {
  CV_Assert(edges.type() == CV_8UC1);
  std::vector<ContactPoint> out;
  cv::Mat ground_stop = cv::Mat::zeros(edges.size(), CV_8UC1);
  const int reach = static_cast<int>(std::round(params.ground_reach_px));
  for (const auto& f : features)
    if (f.label == FeatureClass::ground)
      cv::circle(ground_stop, cv::Point(static_cast<int>(std::round(f.pixel.x)), static_cast<int>(std::round(f.pixel.y))),
                 reach, cv::Scalar(255), cv::FILLED);
  // Trace ends per feature (one entry per distinct end pixel of each feature).
  struct End {
    cv::Point px;
    int feature;
  };
  std::vector<End> ends;
  cv::Mat ended = cv::Mat::zeros(edges.size(), CV_32SC1);  // last feature index + 1 that ended here
  const int half_w = params.window_width_px / 2, half_h = params.window_height_px / 2;
  for (std::size_t i = 0; i < features.size(); ++i) {
    const ClassifiedFeature& f = features[i];
    if (f.label != FeatureClass::obstacle) continue;
    const int fu = static_cast<int>(std::round(f.pixel.x)), fv = static_cast<int>(std::round(f.pixel.y));
    for (int v = std::max(0, fv - half_h); v <= std::min(edges.rows - 1, fv + half_h); ++v) {
      for (int u = std::max(0, fu - half_w); u <= std::min(edges.cols - 1, fu + half_w); ++u) {
        if (edges.at<std::uint8_t>(v, u) == 0) continue;
        const cv::Point end = trace_down(edges, ground_stop, {u, v}, params.max_gap_rows);
        int& mark = ended.at<int>(end.y, end.x);
        if (mark == static_cast<int>(i) + 1) continue;
        mark = static_cast<int>(i) + 1;
        ends.push_back({end, static_cast<int>(i)});
      }
    }
  }
  // Support: traces of min_supporting_features different features end within the radius.
  const double r2 = params.support_radius_px * params.support_radius_px;
  const LensPose lens = lens_pose(camera, robot);
  const double min_row = horizon_row_px(camera) + params.guard_band_px;
  cv::Mat emitted = cv::Mat::zeros(edges.size(), CV_8UC1);
  for (const End& e : ends) {
    if (emitted.at<std::uint8_t>(e.px.y, e.px.x) != 0) continue;
    if (params.min_supporting_features > 1) {
      std::vector<int> support{e.feature};
      for (const End& o : ends) {
        const cv::Point d = o.px - e.px;
        if (d.dot(d) <= r2 && std::find(support.begin(), support.end(), o.feature) == support.end())
          support.push_back(o.feature);
      }
      if (static_cast<int>(support.size()) < params.min_supporting_features) continue;
    }
    emitted.at<std::uint8_t>(e.px.y, e.px.x) = 255;
    if (e.px.y < min_row) continue;
    const GroundHit hit = back_project(camera, lens, cv::Point2d(e.px.x, e.px.y));
    if (!hit.valid()) continue;
    const RangeBearing rb = range_bearing(robot, hit.ground_m);
    if (rb.range_m > params.max_range_m) continue;
    out.push_back(ContactPoint{cv::Point2d(e.px.x, e.px.y), hit.ground_m, rb.range_m, rb.bearing_rad, e.feature});
  }
  return out;
}

void correct_contact_ranges(std::vector<ContactPoint>& contacts, std::span<const ClassifiedFeature> features,
                            const LensPose& lens, double lens_travel_m, const Pose2D& robot,
                            const ProfileParams& params) {
  if (params.foot_radius_px <= 0.0 || !(lens_travel_m > 0.0)) return;
  const cv::Point2d l(lens.x_m, lens.y_m);
  std::vector<double> feet;
  for (auto& c : contacts) {
    const double own_m = cv::norm(c.ground_m - l);
    feet.clear();
    for (const auto& f : features) {
      if (f.label != FeatureClass::obstacle || f.discrepancy_m <= 0.0) continue;
      if (std::fabs(f.pixel.x - c.pixel.x) > params.foot_radius_px || f.pixel.y > c.pixel.y) continue;
      feet.push_back(cv::norm(f.ground_m - l) / (1.0 + f.discrepancy_m / lens_travel_m));
    }
    if (feet.empty()) continue;
    // The median: one mis-tracked feature (D too large) must not pull the obstacle closer.
    std::nth_element(feet.begin(), feet.begin() + static_cast<std::ptrdiff_t>(feet.size() / 2), feet.end());
    const double best_m = feet[feet.size() / 2];
    if (best_m >= own_m) continue;
    c.ground_m = l + (c.ground_m - l) * (best_m / own_m);
    const RangeBearing rb = range_bearing(robot, c.ground_m);
    c.range_m = rb.range_m;
    c.bearing_rad = rb.bearing_rad;
  }
}

std::vector<cv::Point2d> fill_obstacle_spans(std::span<const ContactPoint> contacts,
                                             std::span<const ClassifiedFeature> features, const IptCamera& camera,
                                             const ProfileParams& params) {
  std::vector<cv::Point2d> out;
  if (params.span_max_m <= 0.0 || contacts.size() < 2) return out;
  std::vector<const ContactPoint*> order;
  order.reserve(contacts.size());
  for (const auto& c : contacts) order.push_back(&c);
  std::sort(order.begin(), order.end(), [](const ContactPoint* a, const ContactPoint* b) { return a->pixel.x < b->pixel.x; });
  const double min_row = horizon_row_px(camera) + params.guard_band_px;
  for (std::size_t i = 0; i + 1 < order.size(); ++i) {
    const ContactPoint& a = *order[i];
    const ContactPoint& b = *order[i + 1];
    const double length_m = cv::norm(b.ground_m - a.ground_m);
    if (length_m > params.span_max_m || length_m < 2.0 * params.span_step_m || b.pixel.x - a.pixel.x < 1.0) continue;
    // What shows between the two borders, above their foot line: the obstacle's own face, or
    // the ground behind a gap.
    int obstacle = 0, ground = 0;
    for (const auto& f : features) {
      if (f.pixel.x <= a.pixel.x || f.pixel.x >= b.pixel.x || f.pixel.y < min_row) continue;
      const double t = (f.pixel.x - a.pixel.x) / (b.pixel.x - a.pixel.x);
      if (f.pixel.y >= a.pixel.y + t * (b.pixel.y - a.pixel.y)) continue;
      if (f.label == FeatureClass::obstacle) ++obstacle;
      else if (f.label == FeatureClass::ground) ++ground;
    }
    if (obstacle + ground > 0 && obstacle < params.span_min_obstacle_share * (obstacle + ground)) continue;
    const int steps = static_cast<int>(std::floor(length_m / params.span_step_m));
    for (int k = 1; k < steps; ++k) out.push_back(a.ground_m + (b.ground_m - a.ground_m) * (static_cast<double>(k) / steps));
  }
  return out;
}

}  // namespace visnav::ipt
