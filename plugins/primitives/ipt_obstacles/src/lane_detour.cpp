#include "visnav/ipt_obstacles/lane_detour.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace visnav::ipt {

Status LaneDetourParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<LaneDetourParams>& LaneDetourParams::schema() {
  using P = LaneDetourParams;
  static const auto s = ParamSchema<P>{}
                            .field("body_radius_m", &P::body_radius_m, "robot disc radius").range(0.0, 5.0)
                            .field("clearance_m", &P::clearance_m, "free space kept beyond the body").range(0.0, 5.0)
                            .field("lookahead_m", &P::lookahead_m, "points this far ahead constrain the lane")
                            .range(0.1, 50.0)
                            .field("behind_m", &P::behind_m, "points this far behind the robot still constrain it")
                            .range(0.0, 50.0)
                            .field("min_behind_m", &P::min_behind_m, "at least this far behind, whatever end_s_m says")
                            .range(0.0, 50.0)
                            .field("end_s_m", &P::end_s_m, "the line's end along it from the detour start").range(0.0, 1e12)
                            .field("return_m", &P::return_m, "travel kept for getting back before end_s_m")
                            .range(0.0, 50.0)
                            .field("max_offset_m", &P::max_offset_m, "widest lane searched on either side")
                            .range(0.1, 50.0)
                            .field("offset_step_m", &P::offset_step_m, "lane search resolution").range(0.005, 1.0)
                            .field("aim_ahead_m", &P::aim_ahead_m, "pursuit point along the line").range(0.1, 20.0)
                            .field("done_offset_m", &P::done_offset_m, "back on the line below this offset")
                            .range(0.01, 5.0)
                            .field("done_heading_rad", &P::done_heading_rad, "and within this heading of the line")
                            .range(0.01, 3.2)
                            .field("min_progress_m", &P::min_progress_m, "along-line travel before the detour ends")
                            .range(0.0, 50.0)
                            .field("commit_m", &P::commit_m, "the chosen side is kept within this of an obstacle point")
                            .range(0.0, 50.0)
                            .field("drift_rad_per_m", &P::drift_rad_per_m, "odometry heading drift assumed while passing blind")
                            .range(0.0, 1.0)
                            .field("max_drift_m", &P::max_drift_m, "largest clearance added for that drift").range(0.0, 5.0)
                            .field("max_recoveries", &P::max_recoveries, "closed side near the obstacle: reverse and take the other side this often")
                            .range(0, 10)
                            .field("recover_clear_m", &P::recover_clear_m, "reverse until no obstacle point is this close ahead")
                            .range(0.5, 20.0)
                            .field("max_reverse_m", &P::max_reverse_m, "most reversing along the line per recovery")
                            .range(0.5, 50.0)
                            .field("guard_reach_m", &P::guard_reach_m, "no forward travel into a point this far beyond the body's front; 0 = off")
                            .range(0.0, 5.0)
                            .field("guard_margin_m", &P::guard_margin_m, "the guard's band: body radius + this either side")
                            .range(0.0, 2.0)
                            .field("guard_max_turn_rad", &P::guard_max_turn_rad, "the guard's search for a free heading, either way")
                            .range(0.0, 3.2);
  return s;
}

cv::Point2d LaneDetour::to_line(double x_m, double y_m) const {
  const double c = std::cos(start_.heading_rad), s = std::sin(start_.heading_rad);
  const double dx = x_m - start_.x_m, dy = y_m - start_.y_m;
  return {c * dx + s * dy, -s * dx + c * dy};
}

void LaneDetour::add_points(std::span<const cv::Point2d> points_m) {
  for (const auto& p : points_m) {
    points_.push_back(to_line(p.x, p.y));
    seen_s_.push_back(s_now_);
  }
}

double LaneDetour::hold_m(std::size_t i) const {
  // The unseen length (behind_m), cut for the line's end (return_m before it), but never less
  // than the body radius + clearance: a point seen (the far end of an obstacle's side too) is
  // passed by the body before the robot turns back, also once it is out of view.
  const double cut = std::min(params_.behind_m, params_.end_s_m - params_.return_m - points_[i].x);
  return std::max({params_.min_behind_m, params_.body_radius_m + params_.clearance_m, cut});
}

bool LaneDetour::held(std::size_t i, double s_robot_m) const {
  const double s = points_[i].x;
  return s >= s_robot_m - hold_m(i) && s <= s_robot_m + params_.lookahead_m;
}

double LaneDetour::half_m(std::size_t i, double s_robot_m, bool drift) const {
  if (!drift) return params_.body_radius_m + params_.clearance_m;
  const double d = std::max(0.0, s_robot_m - seen_s_[i]);
  return params_.body_radius_m + params_.clearance_m + std::min(params_.max_drift_m, 0.5 * params_.drift_rad_per_m * d * d);
}

bool LaneDetour::lane_free(double lane_m, double s_robot_m, bool drift) const {
  for (std::size_t i = 0; i < points_.size(); ++i)
    if (std::fabs(points_[i].y - lane_m) < half_m(i, s_robot_m, drift) && held(i, s_robot_m)) return false;
  return true;
}

bool LaneDetour::sweep_free(double from_m, double to_m, double s_robot_m) const {
  // The band from the robot's offset to the target's far clearance: points on the robot's other
  // side (it moves away from them) do not count.
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const double half = half_m(i, s_robot_m);
    const double l = points_[i].y;
    const bool between = to_m >= from_m ? (l > from_m && l < to_m + half) : (l < from_m && l > to_m - half);
    if (between && held(i, s_robot_m)) return false;
  }
  return true;
}

bool LaneDetour::near_obstacle(double s_robot_m) const {
  if (params_.commit_m <= 0.0) return false;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const double s = points_[i].x;
    if (s >= s_robot_m - hold_m(i) && s <= s_robot_m + params_.commit_m) return true;
  }
  return false;
}

bool LaneDetour::clear_to_cross(double s_robot_m) const {
  const double back = params_.body_radius_m + params_.clearance_m;
  for (const auto& p : points_)
    if (p.x >= s_robot_m - back && p.x <= s_robot_m + params_.recover_clear_m) return false;
  return true;
}

double LaneDetour::came_at(double s_m) const {
  // The latest forward pass: back from the end to the first point at or before s_m.
  for (auto it = track_.rbegin(); it != track_.rend(); ++it)
    if (it->x <= s_m) return it->y;
  return 0.0;  // before the detour's start: the replay drove on the line
}

bool LaneDetour::way_blocked(double s_m, double l_m, double dir_on_line_rad) const {
  if (params_.guard_reach_m <= 0.0) return false;
  const double c = std::cos(dir_on_line_rad), sn = std::sin(dir_on_line_rad);
  const double half = params_.body_radius_m + params_.guard_margin_m;
  const double reach = params_.body_radius_m + params_.guard_reach_m;
  for (const auto& p : points_) {
    const double ds = p.x - s_m, dl = p.y - l_m;
    const double fwd = c * ds + sn * dl, lat = -sn * ds + c * dl;
    if (fwd > 0.0 && fwd <= reach && std::fabs(lat) < half) return true;
  }
  return false;
}

std::string LaneDetour::closes_reason(int side) const {
  return std::string("the ") + (side > 0 ? "left" : "right") + " side closes within " + std::to_string(params_.max_offset_m) +
         " m of the line, " + std::to_string(params_.commit_m) +
         " m or less before the obstacle: not crossing to the other side in front of it (" + std::to_string(points_.size()) +
         " obstacle points)";
}

namespace {

/// The turn (robot frame) that makes a robot reversing at lateral offset l_m, heading
/// heading_on_line_rad relative to the line, head for offset target_m a distance aim_m behind it:
/// its back points at the aim, so its nose points at -atan2(target - l, aim) on the line.
double reverse_turn(double l_m, double heading_on_line_rad, double target_m, double aim_m) {
  return std::remainder(-std::atan2(target_m - l_m, aim_m) - heading_on_line_rad, 2.0 * CV_PI);
}

}  // namespace

LaneDecision LaneDetour::decide(const Pose2D& robot) {
  LaneDecision d;
  const cv::Point2d r = to_line(robot.x_m, robot.y_m);
  d.s_m = r.x;
  d.l_m = r.y;
  s_now_ = r.x;
  const double heading_on_line = std::remainder(robot.heading_rad - start_.heading_rad, 2.0 * CV_PI);
  if (r.x >= params_.end_s_m) {
    d.kind = LaneDecision::Kind::done;
    d.reason = "at the line's end";
    return d;
  }
  if (reversing_ && reverse_decided(r, heading_on_line, d)) return d;
  std::optional<double> lane;
  if (choose_lane(r, heading_on_line, lane, d)) return d;
  if (!lane) {
    d.kind = LaneDecision::Kind::blocked;
    d.reason = "no free lane within " + std::to_string(params_.max_offset_m) + " m of the line on either side (" +
               std::to_string(points_.size()) + " obstacle points)";
    return d;
  }
  lane_m_ = *lane;
  d.lane_m = *lane;
  if (*lane == 0.0 && std::fabs(r.y) < params_.done_offset_m && std::fabs(heading_on_line) < params_.done_heading_rad &&
      r.x >= params_.min_progress_m) {
    d.kind = LaneDecision::Kind::done;
    d.reason = "back on the line, past the obstacle";
    return d;
  }
  track_.emplace_back(r.x, r.y);
  steer_to_lane(r, heading_on_line, *lane, d);
  return d;
}

bool LaneDetour::reverse_decided(const cv::Point2d& r, double heading_on_line, LaneDecision& d) {
  if (clear_to_cross(r.x)) {
    // Far enough before every point: the other side, with every point known, for good.
    reversing_ = false;
    side_ = -side_;
    side_locked_ = true;
    lane_m_ = 0.0;
    return false;
  }
  if (reverse_from_s_m_ - r.x >= params_.max_reverse_m) {
    d.kind = LaneDecision::Kind::blocked;
    d.reason = "reversed " + std::to_string(reverse_from_s_m_ - r.x) + " m along the line and an obstacle point is still within " +
               std::to_string(params_.recover_clear_m) + " m ahead (" + std::to_string(points_.size()) + " obstacle points)";
    return true;
  }
  d.kind = LaneDecision::Kind::reverse;
  d.lane_m = came_at(r.x - params_.aim_ahead_m);
  d.heading_rad = reverse_turn(r.y, heading_on_line, d.lane_m, params_.aim_ahead_m);
  d.reason = "reversing along the line until the obstacle is " + std::to_string(params_.recover_clear_m) +
             " m ahead, then the " + (side_ > 0 ? "right" : "left") + " side";
  return true;
}

bool LaneDetour::choose_lane(const cv::Point2d& r, double heading_on_line, std::optional<double>& lane, LaneDecision& d) {
  // Back to the line only when the band the body sweeps on the way there is free too: a point
  // released by its hold on the line may still hold a lane in between.
  if (lane_free(0.0, r.x) && (side_ == 0 || sweep_free(r.y, 0.0, r.x))) {
    lane = 0.0;
  } else if (side_ != 0 && lane_m_ != 0.0 && lane_free(lane_m_, r.x)) {
    lane = lane_m_;  // keep a free target: re-choosing every cycle would swing
  } else {
    return choose_side_lane(r, heading_on_line, lane, d);
  }
  return false;
}

std::optional<double> LaneDetour::nearest_free_lane(int side, const cv::Point2d& r) const {
  // The drift margin widens a lane but does not close a side: without a lane with the margins,
  // the lane free of body radius + clearance nearest the robot's offset (the least move).
  for (double l = params_.offset_step_m; l <= params_.max_offset_m + 1e-9; l += params_.offset_step_m)
    if (lane_free(side * l, r.x)) return side * l;
  std::optional<double> best;
  for (double l = params_.offset_step_m; l <= params_.max_offset_m + 1e-9; l += params_.offset_step_m)
    if (lane_free(side * l, r.x, false) && (!best || std::fabs(side * l - r.y) < std::fabs(*best - r.y))) best = side * l;
  return best;
}

bool LaneDetour::choose_side_lane(const cv::Point2d& r, double heading_on_line, std::optional<double>& lane,
                                  LaneDecision& d) {
  // The free lane nearest the line, on the chosen side first.
  std::optional<double> left = nearest_free_lane(1, r), right = nearest_free_lane(-1, r);
  const bool own_closed = side_ != 0 && !(side_ > 0 ? left : right);
  const bool other_open = side_ != 0 && (side_ > 0 ? right : left).has_value();
  if (own_closed && side_locked_) {
    // The side taken after a recovery closes too: no third try.
    d.kind = LaneDecision::Kind::blocked;
    d.reason = closes_reason(side_) + "; both sides closed, the other one after " + std::to_string(recoveries_) +
               " recovery(ies) by reversing";
    return true;
  }
  if (own_closed && near_obstacle(r.x)) {
    if (other_open && recoveries_ < params_.max_recoveries) {
      ++recoveries_;
      reversing_ = true;
      reverse_from_s_m_ = r.x;
      d.kind = LaneDecision::Kind::reverse;
      d.lane_m = came_at(r.x - params_.aim_ahead_m);
      d.heading_rad = reverse_turn(r.y, heading_on_line, d.lane_m, params_.aim_ahead_m);
      d.reason = closes_reason(side_) + ": reversing along the line until the obstacle is " +
                 std::to_string(params_.recover_clear_m) + " m ahead, then the " + (side_ > 0 ? "right" : "left") + " side";
      return true;
    }
    d.kind = LaneDecision::Kind::blocked;
    d.reason = closes_reason(side_) + (other_open ? "; recovery by reversing tried " + std::to_string(recoveries_) + " time(s)"
                                                  : "; the other side closes too");
    return true;
  }
  if (side_ > 0 && left) lane = left;
  else if (side_ < 0 && right) lane = right;
  else if (left && right) lane = std::fabs(*left) <= std::fabs(*right) ? left : right;
  else lane = left ? left : right;
  if (lane) side_ = *lane > 0 ? 1 : -1;
  return false;
}

void LaneDetour::steer_to_lane(const cv::Point2d& r, double heading_on_line, double lane, LaneDecision& d) const {
  double aim_line = std::atan2(lane - r.y, params_.aim_ahead_m);  // relative to the line
  d.kind = LaneDecision::Kind::drive;
  d.reason = lane == 0.0 ? std::string("returning to the line")
                         : "lane " + std::to_string(lane) + " m " + (lane > 0 ? "left" : "right") + " of the line";
  if (way_blocked(r.x, r.y, aim_line)) {
    // The pursuit's direction runs into a known point: the nearest free direction, towards the
    // target lane first (its side of the line), then the other way.
    const std::optional<double> free_dir = free_direction(r, aim_line, lane - r.y >= 0.0 ? 1.0 : -1.0);
    if (!free_dir) {
      d.kind = LaneDecision::Kind::blocked;
      d.reason = "a known obstacle point lies in the body's way within " + std::to_string(params_.guard_reach_m) +
                 " m in every direction within " + std::to_string(params_.guard_max_turn_rad) + " rad of the line (" +
                 std::to_string(points_.size()) + " obstacle points)";
      return;
    }
    aim_line = *free_dir;
    d.reason += " (steering round a point in the way)";
  }
  d.heading_rad = std::remainder(aim_line - heading_on_line, 2.0 * CV_PI);
  d.hold_forward = way_blocked(r.x, r.y, heading_on_line);
}

std::optional<double> LaneDetour::free_direction(const cv::Point2d& r, double aim_line, double toward) const {
  std::optional<double> free_dir;
  const double step = 0.05;
  for (double k = step; k <= 2.0 * params_.guard_max_turn_rad + 1e-9 && !free_dir; k += step)
    for (const double sign : {toward, -toward}) {
      const double dir = aim_line + sign * k;
      if (std::fabs(dir) > params_.guard_max_turn_rad) continue;
      if (!way_blocked(r.x, r.y, dir)) {
        free_dir = dir;
        break;
      }
    }
  return free_dir;
}

}  // namespace visnav::ipt
