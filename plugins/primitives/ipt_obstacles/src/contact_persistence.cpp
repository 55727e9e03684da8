#include "visnav/ipt_obstacles/contact_persistence.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::ipt {

namespace {
constexpr double kSamePosition_m = 0.02;  // sightings from robot positions closer than this: one pair
}  // namespace

Status ContactPersistenceParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<ContactPersistenceParams>& ContactPersistenceParams::schema() {
  using P = ContactPersistenceParams;
  static const auto s = ParamSchema<P>{}
                            .field("min_baseline_m", &P::min_baseline_m,
                                   "robot positions of two sightings of one contact at least this far apart")
                            .range(0.01, 10.0)
                            .field("max_radius_m", &P::max_radius_m, "two sightings of one contact at most this far apart")
                            .range(0.01, 5.0)
                            .field("radius_ratio", &P::radius_ratio,
                                   "and at most this fraction of the robot travel between them (< 1: a point moving "
                                   "with the robot never confirms itself)")
                            .range(0.01, 0.99)
                            .field("min_views", &P::min_views, "distinct robot positions that saw the point")
                            .range(2, 1000)
                            .field("min_view_share", &P::min_view_share,
                                   "share of the pairs between the first and the last view that saw the point "
                                   "(0 = off)")
                            .range(0.0, 1.0);
  return s;
}

void ContactPersistence::add(std::span<const cv::Point2d> points_m, const cv::Point2d& robot_m, double odom_distance_m) {
  for (const auto& p : points_m) sightings_.push_back({p, robot_m, odom_distance_m});
  pairs_m_.push_back(odom_distance_m);
}

void ContactPersistence::forget(double odom_distance_m, double memory_m) {
  std::erase_if(sightings_, [&](const Sighting& s) { return std::fabs(odom_distance_m - s.odom_m) > memory_m; });
  std::erase_if(pairs_m_, [&](double m) { return std::fabs(odom_distance_m - m) > memory_m; });
}

bool ContactPersistence::is_confirmed(std::size_t i) const {
  const Sighting& a = sightings_[i];
  bool far_match = false;
  std::vector<cv::Point2d>& views = views_scratch_;  // reused: this runs for every sighting every frame
  views.assign(1, a.robot_m);
  double first_m = a.odom_m, last_m = a.odom_m;
  for (std::size_t j = 0; j < sightings_.size(); ++j) {
    if (j == i) continue;
    const Sighting& b = sightings_[j];
    const double baseline = cv::norm(a.robot_m - b.robot_m);
    const double gap = cv::norm(a.point_m - b.point_m);
    if (gap > std::min(params_.max_radius_m, params_.radius_ratio * std::max(baseline, params_.min_baseline_m))) continue;
    if (baseline >= params_.min_baseline_m && gap <= std::min(params_.max_radius_m, params_.radius_ratio * baseline))
      far_match = true;
    if (std::none_of(views.begin(), views.end(), [&](const cv::Point2d& v) { return cv::norm(v - b.robot_m) < kSamePosition_m; })) {
      views.push_back(b.robot_m);
      first_m = std::min(first_m, b.odom_m);
      last_m = std::max(last_m, b.odom_m);
    }
    if (far_match && static_cast<int>(views.size()) >= params_.min_views && params_.min_view_share <= 0.0) return true;
  }
  if (!far_match || static_cast<int>(views.size()) < params_.min_views) return false;
  // The pairs made between the first and the last view (each pair is one add()).
  const auto pairs = std::count_if(pairs_m_.begin(), pairs_m_.end(),
                                   [&](double m) { return m >= first_m - 1e-9 && m <= last_m + 1e-9; });
  return static_cast<double>(views.size()) >= params_.min_view_share * static_cast<double>(std::max<std::ptrdiff_t>(pairs, 1));
}

std::vector<cv::Point2d> ContactPersistence::confirmed(const std::function<bool(const cv::Point2d&)>& candidate) const {
  std::vector<cv::Point2d> out;
  for (std::size_t i = 0; i < sightings_.size(); ++i)
    if ((!candidate || candidate(sightings_[i].point_m)) && is_confirmed(i)) out.push_back(sightings_[i].point_m);
  return out;
}

std::vector<cv::Point2d> ContactPersistence::confirmed_since(std::size_t first) const {
  std::vector<cv::Point2d> out;
  for (std::size_t i = first; i < sightings_.size(); ++i)
    if (is_confirmed(i)) out.push_back(sightings_[i].point_m);
  return out;
}

std::vector<cv::Point2d> ContactPersistence::all() const {
  std::vector<cv::Point2d> out;
  out.reserve(sightings_.size());
  for (const auto& s : sightings_) out.push_back(s.point_m);
  return out;
}

}  // namespace visnav::ipt
