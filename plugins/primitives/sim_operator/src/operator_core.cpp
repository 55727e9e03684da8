#include "operator_core.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace visnav::simop {

namespace {
double wrap(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}
}  // namespace

Status OperatorParams::validate() const {
  if (!(speed_mps > 0.0 && speed_mps <= 3.0)) return fail("speed_mps must be in (0, 3]");
  if (!(max_angular_radps > 0.0)) return fail("max_angular_radps must be > 0");
  if (!(turn_tolerance_rad > 0.0)) return fail("turn_tolerance_rad must be > 0");
  if (heading_gain_per_s < 0.0 || cross_track_gain_per_ms < 0.0) return fail("gains must be >= 0");
  return ok();
}

ScriptedOperatorCore::ScriptedOperatorCore(std::vector<OperatorLeg> legs, OperatorParams params, bool closed)
    : legs_(std::move(legs)), params_(params), closed_(closed) {
  done_ = legs_.empty();
}

OperatorAction ScriptedOperatorCore::update(const Pose2D& pose) {
  OperatorAction action;
  if (done_) {
    action.done = true;
    action.leg = static_cast<int>(legs_.size());
    return action;
  }
  if (closing_) {
    // Every leg driven: face the first leg's direction again, then the route is done.
    action.closing = true;
    action.leg = static_cast<int>(legs_.size());
    const cv::Point2d d0 = legs_.front().to_m - legs_.front().from_m;
    const double error = wrap(std::atan2(d0.y, d0.x) - pose.heading_rad);
    if (std::abs(error) > params_.turn_tolerance_rad) {
      const double w = std::clamp(params_.heading_gain_per_s * error, -params_.max_angular_radps,
                                  params_.max_angular_radps);
      action.command.angular_radps = std::abs(w) < 0.05 ? std::copysign(0.05, w) : w;
      return action;
    }
    done_ = true;
    action.done = true;
    return action;
  }
  const OperatorLeg& leg = legs_[leg_];
  action.leg = static_cast<int>(leg_);
  const cv::Point2d d = leg.to_m - leg.from_m;
  const double length_m = std::hypot(d.x, d.y);
  const double leg_heading = std::atan2(d.y, d.x);
  const cv::Point2d u = length_m > 0 ? d * (1.0 / length_m) : cv::Point2d(1, 0);
  const cv::Point2d p(pose.x_m - leg.from_m.x, pose.y_m - leg.from_m.y);
  const double along_m = p.x * u.x + p.y * u.y;
  const double cross_m = -p.x * u.y + p.y * u.x;  // left of the leg positive
  const double heading_error = wrap(leg_heading - pose.heading_rad);

  if (turning_) {
    if (std::abs(heading_error) > params_.turn_tolerance_rad) {
      const double w = std::clamp(params_.heading_gain_per_s * heading_error, -params_.max_angular_radps,
                                  params_.max_angular_radps);
      action.command.angular_radps = std::abs(w) < 0.05 ? std::copysign(0.05, w) : w;
      return action;  // primitive empty: not teaching while turning in place
    }
    turning_ = false;
  }
  if (along_m >= length_m) {
    // Waypoint reached: stop; the next update turns towards the next leg.
    ++leg_;
    turning_ = true;
    if (leg_ >= legs_.size()) {
      if (closed_) {
        closing_ = true;
        action.closing = true;
      } else {
        done_ = true;
        action.done = true;
      }
    }
    return action;
  }
  const double remaining_m = length_m - along_m;
  double v = params_.speed_mps;
  if (remaining_m < params_.slow_down_m) v *= 0.4 + 0.6 * remaining_m / params_.slow_down_m;
  const double w = params_.heading_gain_per_s * heading_error - params_.cross_track_gain_per_ms * cross_m;
  action.command = Twist{v, std::clamp(w, -params_.max_angular_radps, params_.max_angular_radps)};
  action.primitive = leg.kind;
  return action;
}

Result<std::vector<OperatorLeg>> make_legs(const std::vector<cv::Point2d>& waypoints,
                                           const std::vector<std::string>& waypoint_kinds, bool closed,
                                           const std::vector<std::pair<std::string, std::string>>& kind_map,
                                           const std::string& force_kind) {
  if (waypoints.size() < 2) return fail("a route needs at least two waypoints");
  if (waypoint_kinds.size() != waypoints.size()) return fail("one kind per waypoint expected");
  std::vector<OperatorLeg> legs;
  const std::size_t n = closed ? waypoints.size() : waypoints.size() - 1;
  for (std::size_t i = 0; i < n; ++i) {
    OperatorLeg leg;
    leg.from_m = waypoints[i];
    leg.to_m = waypoints[(i + 1) % waypoints.size()];
    if (!force_kind.empty()) {
      leg.kind = force_kind;
    } else {
      const std::string& k = waypoint_kinds[i];
      auto it = std::find_if(kind_map.begin(), kind_map.end(), [&](const auto& e) { return e.first == k; });
      if (it == kind_map.end()) return fail("waypoint kind '" + k + "' has no mapping to a map edge kind");
      leg.kind = it->second;
    }
    if (cv::norm(leg.to_m - leg.from_m) < 1e-6) return fail("waypoints " + std::to_string(i) + " and next coincide");
    legs.push_back(std::move(leg));
  }
  return legs;
}

}  // namespace visnav::simop
