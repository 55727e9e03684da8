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
  if (!(min_turning_radius_m >= 0.0 && min_turning_radius_m <= 100.0))
    return fail(ErrorCode::out_of_range, {"", 0, "min_turning_radius_m"},
                "value " + std::to_string(min_turning_radius_m) + " must be in [0, 100] m");
  if (!(arc_speed_mps > 0.0 && arc_speed_mps <= speed_mps))
    return fail(ErrorCode::out_of_range, {"", 0, "arc_speed_mps"},
                "value " + std::to_string(arc_speed_mps) + " must be in (0, speed_mps]");
  return ok();
}

namespace {
double leg_heading_rad(const OperatorLeg& leg) { return std::atan2(leg.to_m.y - leg.from_m.y, leg.to_m.x - leg.from_m.x); }
}  // namespace

Result<LegArcs> leg_arcs(const std::vector<OperatorLeg>& legs, bool closed, double min_turning_radius_m) {
  LegArcs arcs;
  arcs.lead_in_m.assign(legs.size(), 0.0);
  arcs.lead_out_m.assign(legs.size(), 0.0);
  if (!(min_turning_radius_m > 0.0)) return arcs;
  const std::size_t corners = closed ? legs.size() : legs.size() - std::min<std::size_t>(legs.size(), 1);
  for (std::size_t i = 0; i < corners; ++i) {
    const std::size_t next = (i + 1) % legs.size();
    const double turn = std::abs(wrap(leg_heading_rad(legs[next]) - leg_heading_rad(legs[i])));
    if (turn > 170.0 * std::numbers::pi / 180.0)
      return fail(ErrorCode::out_of_range, {"", 0, "min_turning_radius_m"},
                  "the corner after leg " + std::to_string(i) + " turns " + std::to_string(turn * 180.0 / std::numbers::pi) +
                      " deg: more than 170 deg cannot be driven as one arc");
    const double d = min_turning_radius_m * std::tan(turn / 2.0);
    arcs.lead_out_m[i] = d;
    arcs.lead_in_m[next] = d;
  }
  for (std::size_t i = 0; i < legs.size(); ++i) {
    const double length_m = cv::norm(legs[i].to_m - legs[i].from_m);
    if (arcs.lead_in_m[i] + arcs.lead_out_m[i] >= length_m)
      return fail(ErrorCode::out_of_range, {"", 0, "min_turning_radius_m"},
                  "leg " + std::to_string(i) + " (" + std::to_string(length_m) + " m) is too short for its corner arcs (" +
                      std::to_string(arcs.lead_in_m[i]) + " m + " + std::to_string(arcs.lead_out_m[i]) +
                      " m) at a turning radius of " + std::to_string(min_turning_radius_m) + " m");
  }
  return arcs;
}

ScriptedOperatorCore::ScriptedOperatorCore(std::vector<OperatorLeg> legs, OperatorParams params, bool closed)
    : legs_(std::move(legs)), params_(params), closed_(closed) {
  done_ = legs_.empty();
  lead_in_m_.assign(legs_.size(), 0.0);
  lead_out_m_.assign(legs_.size(), 0.0);
  if (arcs() && !legs_.empty()) {
    // Checked by the caller (leg_arcs); legs too short for their arcs get no arcs rather than UB.
    if (auto a = leg_arcs(legs_, closed_, params_.min_turning_radius_m)) {
      lead_in_m_ = std::move(a->lead_in_m);
      lead_out_m_ = std::move(a->lead_out_m);
    }
    turning_ = false;  // a car starts as it stands; it cannot turn on the spot to face the leg
  }
}

Twist ScriptedOperatorCore::arc_command(double heading_error) const {
  if (std::abs(heading_error) <= params_.turn_tolerance_rad) return Twist{};
  const double v = params_.arc_speed_mps;
  const double w_max = std::min(params_.max_angular_radps, v / params_.min_turning_radius_m);
  const double w = std::clamp(std::abs(params_.heading_gain_per_s * heading_error), std::min(0.05, w_max), w_max);
  return Twist{v, std::copysign(w, heading_error)};
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
    if (arcs()) {
      action.command = arc_command(error);
      if (action.command.linear_mps != 0.0) return action;
      done_ = true;
      action.done = true;
      return action;
    }
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

  if (turning_ && arcs()) {
    // On the corner arc into this leg: nothing is taught until it is done.
    action.command = arc_command(heading_error);
    if (action.command.linear_mps != 0.0) return action;
    turning_ = false;
  }
  if (turning_) {
    if (std::abs(heading_error) > params_.turn_tolerance_rad) {
      const double w = std::clamp(params_.heading_gain_per_s * heading_error, -params_.max_angular_radps,
                                  params_.max_angular_radps);
      action.command.angular_radps = std::abs(w) < 0.05 ? std::copysign(0.05, w) : w;
      return action;  // primitive empty: not teaching while turning in place
    }
    turning_ = false;
  }
  const double end_m = length_m - lead_out_m_[leg_];
  if (along_m >= end_m) {
    // Waypoint (or, in arc mode, the start of the corner arc) reached: stop / start the arc; the
    // next update turns towards the next leg.
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
    // Arc mode: no stop between the leg and its corner arc, the arc starts this tick.
    if (arcs() && !done_) return update(pose);
    return action;
  }
  const double remaining_m = end_m - along_m;
  double v = params_.speed_mps;
  if (remaining_m < params_.slow_down_m) {
    if (arcs() && lead_out_m_[leg_] > 0.0)  // into the arc at the arc's speed
      v = params_.arc_speed_mps + (v - params_.arc_speed_mps) * remaining_m / params_.slow_down_m;
    else
      v *= 0.4 + 0.6 * remaining_m / params_.slow_down_m;
  }
  const double w = params_.heading_gain_per_s * heading_error - params_.cross_track_gain_per_ms * cross_m;
  action.command = Twist{v, std::clamp(w, -params_.max_angular_radps, params_.max_angular_radps)};
  // Arc mode: the first leg of a closed route is taught from where the closing arc will end.
  if (!(arcs() && leg_ == 0 && closed_ && along_m < lead_in_m_[0])) action.primitive = leg.kind;
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
