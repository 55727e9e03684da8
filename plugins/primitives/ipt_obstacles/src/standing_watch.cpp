// A standing obstacle on the path found while the replay drives (see the header).
#include "visnav/ipt_obstacles/standing_watch.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <set>

namespace visnav::ipt {

Status StandingWatchParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<StandingWatchParams>& StandingWatchParams::schema() {
  using P = StandingWatchParams;
  static const auto s = ParamSchema<P>{}
                            .field("corridor_half_width_m", &P::corridor_half_width_m, "corridor half width, m")
                            .range(0.05, 5.0)
                            .field("max_range_m", &P::max_range_m, "points farther ahead are ignored, m").range(0.5, 50.0)
                            .field("depth_band_m", &P::depth_band_m, "forward depth of one face, m").range(0.05, 5.0)
                            .field("min_points", &P::min_points, "face points that fire").range(1, 10000)
                            .field("min_batches", &P::min_batches, "distinct triangulations that fire").range(1, 1000)
                            .field("one_batch_points", &P::one_batch_points,
                                   "face points that fire from fewer triangulations; 0 = off")
                            .range(0, 100000)
                            .field("memory_m", &P::memory_m, "points kept for this travel, m").range(0.1, 20.0)
                            .field("extent_half_width_m", &P::extent_half_width_m, "lateral extent reach, m")
                            .range(0.05, 10.0)
                            .field("min_width_m", &P::min_width_m, "lateral span of a face, m").range(0.0, 10.0);
  return s;
}

NearTriangulationParams StandingWatch::triangulation_params() {
  NearTriangulationParams p;
  p.baseline_m = 0.6;
  p.max_corners = 600;
  p.quality_level = 0.003;
  p.max_range_m = 5.0;
  p.max_rotation_rad = 0.02;  // the follower's steering: the odometry's heading error makes stray points
  p.min_height_m = 0.3;       // mis-triangulated ground lies low
  return p;
}

void StandingWatch::reset() {
  kept_.clear();
  batch_ = 0;
}

StandingVerdict StandingWatch::add(std::span<const cv::Point2d> points_m, const Pose2D& pose, double odometer_m) {
  std::erase_if(kept_, [&](const Kept& k) { return std::fabs(odometer_m - k.odometer_m) > params_.memory_m; });
  if (!points_m.empty()) {
    ++batch_;
    for (const auto& p : points_m) kept_.push_back(Kept{p, odometer_m, batch_});
  }
  return judge(pose);
}

StandingVerdict StandingWatch::judge(const Pose2D& pose) const {
  StandingVerdict v;
  const double c = std::cos(pose.heading_rad), sn = std::sin(pose.heading_rad);
  struct Rel {
    double fwd, lat;
    int batch;
    std::size_t index;
  };
  std::vector<Rel> corridor, all;
  for (std::size_t i = 0; i < kept_.size(); ++i) {
    const double dx = kept_[i].p.x - pose.x_m, dy = kept_[i].p.y - pose.y_m;
    const Rel r{c * dx + sn * dy, -sn * dx + c * dy, kept_[i].batch, i};
    if (r.fwd <= 0.0 || r.fwd > params_.max_range_m) continue;
    if (std::fabs(r.lat) <= params_.extent_half_width_m) all.push_back(r);
    if (std::fabs(r.lat) <= params_.corridor_half_width_m) corridor.push_back(r);
  }
  if (corridor.empty()) return v;
  std::sort(corridor.begin(), corridor.end(), [](const Rel& a, const Rel& b) { return a.fwd < b.fwd; });
  // The densest window of depth_band_m (the nearest one on a tie).
  std::size_t best_first = 0, best_count = 0, last = 0;
  for (std::size_t first = 0; first < corridor.size(); ++first) {
    last = std::max(last, first);
    while (last + 1 < corridor.size() && corridor[last + 1].fwd - corridor[first].fwd <= params_.depth_band_m) ++last;
    const std::size_t count = last - first + 1;
    if (count > best_count) {
      best_count = count;
      best_first = first;
    }
  }
  std::set<int> batches;
  for (std::size_t i = best_first; i < best_first + best_count; ++i) batches.insert(corridor[i].batch);
  v.in_face = static_cast<int>(best_count);
  v.batches = static_cast<int>(batches.size());
  // The face's distance: the median of its points (a stray corner before it does not count).
  v.range_m = corridor[best_first + best_count / 2].fwd;
  const double near_m = corridor[best_first].fwd;
  const double far_m = corridor[best_first + best_count - 1].fwd;
  double left = -std::numeric_limits<double>::infinity(), right = std::numeric_limits<double>::infinity();
  for (const Rel& r : all) {
    if (r.fwd < near_m - 0.5 * params_.depth_band_m || r.fwd > far_m + 0.5 * params_.depth_band_m) continue;
    left = std::max(left, r.lat);
    right = std::min(right, r.lat);
    v.points.push_back(kept_[r.index].p);
  }
  v.left_m = left;
  v.right_m = right;
  const bool seen_again = v.in_face >= params_.min_points && v.batches >= params_.min_batches;
  const bool seen_well = params_.one_batch_points > 0 && v.in_face >= params_.one_batch_points;
  v.found = (seen_again || seen_well) && left - right >= params_.min_width_m;
  return v;
}

}  // namespace visnav::ipt
