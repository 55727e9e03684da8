// Back off and look (see the header).
#include "visnav/ipt_obstacles/back_off_look.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace visnav::ipt {

Status BackOffLookParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<BackOffLookParams>& BackOffLookParams::schema() {
  using P = BackOffLookParams;
  static const auto s = ParamSchema<P>{}
                            .field("distance_m", &P::distance_m, "reverse travel, m").range(0.1, 10.0)
                            .field("speed_mps", &P::speed_mps, "reverse speed, m/s").range(0.01, 1.0)
                            .field("heading_gain_per_s", &P::heading_gain_per_s, "heading hold gain, 1/s").range(0.0, 20.0)
                            .field("max_angular_radps", &P::max_angular_radps, "turn-rate limit, rad/s").range(0.0, 5.0)
                            .field("min_points", &P::min_points, "corridor points that make an obstacle").range(1, 10000)
                            .field("corridor_half_width_m", &P::corridor_half_width_m, "corridor half width, m")
                            .range(0.05, 5.0)
                            .field("reach_m", &P::reach_m, "points this far ahead count, m").range(0.1, 50.0)
                            .field("face_depth_m", &P::face_depth_m, "lateral extent from points this near the face's distance, m; 0 = all")
                            .range(0.0, 50.0);
  return s;
}

void BackOffLook::begin(const Pose2D& pose, double odometer_m) {
  start_odometer_m_ = odometer_m;
  heading_rad_ = pose.heading_rad;
  points_.clear();
}

void BackOffLook::add_points(std::span<const cv::Point2d> points_m) { points_.insert(points_.end(), points_m.begin(), points_m.end()); }

BackOffLook::Step BackOffLook::step(const Pose2D& pose, double odometer_m) const {
  Step s;
  if (std::fabs(start_odometer_m_ - odometer_m) >= params_.distance_m) {
    s.done = true;
    return s;
  }
  const double error = std::remainder(heading_rad_ - pose.heading_rad, 2.0 * CV_PI);
  s.command.linear_mps = -params_.speed_mps;
  s.command.angular_radps = std::clamp(params_.heading_gain_per_s * error, -params_.max_angular_radps, params_.max_angular_radps);
  return s;
}

BackOffVerdict BackOffLook::verdict(const Pose2D& pose) const {
  BackOffVerdict v;
  const double c = std::cos(heading_rad_), sn = std::sin(heading_rad_);
  std::vector<double> ranges;
  double left = -std::numeric_limits<double>::infinity(), right = std::numeric_limits<double>::infinity();
  // (forward, lateral) of a point on the held heading from the final pose.
  auto relative = [&](const cv::Point2d& p) {
    const double dx = p.x - pose.x_m, dy = p.y - pose.y_m;
    return cv::Point2d(c * dx + sn * dy, -sn * dx + c * dy);
  };
  for (const auto& p : points_) {
    const auto [fwd, lat] = relative(p);
    if (fwd <= 0.0 || fwd > params_.reach_m || std::fabs(lat) > 3.0) continue;
    ++v.ahead;
    left = std::max(left, lat);
    right = std::min(right, lat);
    if (std::fabs(lat) <= params_.corridor_half_width_m) {
      ++v.in_corridor;
      ranges.push_back(fwd);
    }
  }
  v.found = v.in_corridor >= params_.min_points;
  if (v.found) {
    const auto mid = ranges.begin() + static_cast<std::ptrdiff_t>(ranges.size() / 2);
    std::nth_element(ranges.begin(), mid, ranges.end());
    v.range_m = *mid;
  }
  if (v.found && params_.face_depth_m > 0.0) {
    // The extent of the face itself: points ahead at other depths (clutter beside it, the
    // ground's own mis-triangulated corners) do not widen it.
    left = -std::numeric_limits<double>::infinity();
    right = std::numeric_limits<double>::infinity();
    for (const auto& p : points_) {
      const auto [fwd, lat] = relative(p);
      if (std::fabs(fwd - v.range_m) > params_.face_depth_m || std::fabs(lat) > 3.0) continue;
      left = std::max(left, lat);
      right = std::min(right, lat);
    }
  }
  if (v.ahead > 0) {
    v.left_m = left;
    v.right_m = right;
  }
  return v;
}

}  // namespace visnav::ipt
