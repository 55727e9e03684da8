// When a stopped robot may cross a walking person's way (see the header).
#include "visnav/ipt_obstacles/crossing_policy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace visnav::ipt {

namespace {

std::string fmt(double v, int decimals = 2) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

const char* to_string(CrossingDecision::Kind kind) {
  switch (kind) {
    case CrossingDecision::Kind::no_track: return "no_track";
    case CrossingDecision::Kind::wait: return "wait";
    case CrossingDecision::Kind::go: return "go";
  }
  return "?";
}

Result<std::optional<MovingPoint>> locate_moving(const cv::Mat& changed, const IptCamera& camera, int min_changed_px) {
  if (changed.type() != CV_8UC1 || changed.rows != camera.height_px || changed.cols != camera.width_px)
    return Error{"locate_moving: expected a " + std::to_string(camera.width_px) + "x" + std::to_string(camera.height_px) +
                     " CV_8UC1 mask",
                 ErrorCode::invalid_value};
  std::vector<int> per_column(static_cast<std::size_t>(changed.cols), 0);
  int total = 0;
  for (int v = 0; v < changed.rows; ++v) {
    const std::uint8_t* row = changed.ptr<std::uint8_t>(v);
    for (int u = 0; u < changed.cols; ++u)
      if (row[u] != 0) {
        ++per_column[static_cast<std::size_t>(u)];
        ++total;
      }
  }
  if (total < std::max(1, min_changed_px)) return std::optional<MovingPoint>{};
  // The median changed column: robust to a few changed pixels elsewhere.
  int u_med = 0;
  for (int seen = 0; u_med < changed.cols; ++u_med) {
    seen += per_column[static_cast<std::size_t>(u_med)];
    if (2 * seen >= total) break;
  }
  // The feet: the lowest changed row near that column (a body a few dozen pixels wide).
  const int half = std::max(4, camera.width_px / 16);
  int v_low = -1;
  for (int v = changed.rows - 1; v >= 0 && v_low < 0; --v) {
    const std::uint8_t* row = changed.ptr<std::uint8_t>(v);
    for (int u = std::max(0, u_med - half); u <= std::min(changed.cols - 1, u_med + half); ++u)
      if (row[u] != 0) {
        v_low = v;
        break;
      }
  }
  const double horizon = horizon_row_px(camera);
  if (v_low < 0 || v_low <= horizon + 1.0) return std::optional<MovingPoint>{};
  MovingPoint m;
  m.changed_px = total;
  m.contact_visible = v_low < camera.height_px - 3;
  const double v = m.contact_visible ? v_low + 0.5 : camera.height_px - 0.5;
  const GroundHit hit = back_project(camera, lens_pose(camera, Pose2D{}), {u_med + 0.5, v});
  if (!hit.valid()) return std::optional<MovingPoint>{};
  m.ground_m = to_robot_frame(Pose2D{}, hit.ground_m);
  return std::optional<MovingPoint>{m};
}

Status CrossingParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (forget_s < window_s)
    return Error{"forget_s " + fmt(forget_s) + " must be at least window_s " + fmt(window_s), ErrorCode::inconsistent,
                 ErrorLocation({}, 0, "forget_s")};
  // The lane test assumes a person outside it cannot touch the robot's body.
  if (speed_mps > 0.0 && lane_half_width_m < body_radius_m + person_radius_m)
    return Error{"lane_half_width_m " + fmt(lane_half_width_m) + " must be at least body_radius_m + person_radius_m " +
                     fmt(body_radius_m + person_radius_m),
                 ErrorCode::inconsistent, ErrorLocation({}, 0, "lane_half_width_m")};
  return ok();
}

const ParamSchema<CrossingParams>& CrossingParams::schema() {
  using P = CrossingParams;
  static const auto s =
      ParamSchema<P>{}
          .field("lane_half_width_m", &P::lane_half_width_m, "half width of the robot's lane (body + a person + margin), m")
          .range(0.1, 5.0)
          .field("crossing_s", &P::crossing_s, "time the stopped robot needs to clear a lane just ahead, s")
          .range(0.1, 60.0)
          .field("away_clear_m", &P::away_clear_m, "walking away or standing this far beyond the lane's edge: go, m")
          .range(0.0, 10.0)
          .field("min_speed_mps", &P::min_speed_mps, "slower counts as standing, m/s")
          .range(0.01, 5.0)
          .field("window_s", &P::window_s, "track fit window, s")
          .range(0.1, 10.0)
          .field("forget_s", &P::forget_s, "no point for this long drops the track, s")
          .range(0.1, 60.0)
          .field("min_points", &P::min_points, "points in the window before a decision")
          .range(2, 1000)
          .field("speed_mps", &P::speed_mps, "speed the robot crosses at (0: the hand-set crossing_s), m/s")
          .range(0.0, 2.0)
          .field("accel_mps2", &P::accel_mps2, "the robot's acceleration from rest, m/s^2")
          .range(0.05, 10.0)
          .field("body_radius_m", &P::body_radius_m, "the robot's body radius, m")
          .range(0.05, 2.0)
          .field("person_radius_m", &P::person_radius_m, "a person's body radius, m")
          .range(0.05, 1.0)
          .field("margin_m", &P::margin_m, "driven beyond the person's far side, m")
          .range(0.0, 2.0)
          .field("margin_s", &P::margin_s, "time the arrival must leave beyond the clear time, s")
          .range(0.0, 30.0)
          .field("pass_fit_m", &P::pass_fit_m, "a pass's speed is fitted to the points this near the line, m")
          .range(0.05, 2.0)
          .field("approach_m", &P::approach_m, "a way farther ahead is approached to its edge first, m")
          .range(0.0, 10.0);
  return s;
}

double clear_distance_m(const CrossingParams& params, double way_ahead_m) {
  return std::max(0.0, way_ahead_m) + params.person_radius_m + params.body_radius_m + params.margin_m;
}

double clear_time_s(const CrossingParams& params, double way_ahead_m) {
  const double d = clear_distance_m(params, way_ahead_m);
  const double v = params.speed_mps, a = params.accel_mps2;
  if (v <= 0.0) return params.crossing_s;
  if (d >= v * v / (2.0 * a)) return d / v + v / (2.0 * a);
  return std::sqrt(2.0 * d / a);
}

void CrossingPolicy::observe(double time_s, const MovingPoint& point) {
  const double y = point.ground_m.y;
  if (last_seen_s_ >= 0.0 && time_s - last_seen_s_ <= params_.window_s && ((last_y_ < 0.0) != (y < 0.0))) {
    const int dir = y > last_y_ ? 1 : -1;  // a pass: it walked across the robot's line
    // Back across the line before it was seen pass_fit_m beyond it on the pass's side: the
    // located feet jittering about the line (their spread), not a return. Counted as one, it
    // taught a 0.1-0.4 s return and held the robot at a pacing person's way (campus seed 10).
    const bool jitter = last_pass_dir_ == -dir && farthest_since_pass_m_ < params_.pass_fit_m;
    if (!jitter) {
      if (last_pass_dir_ == -dir) return_after_s_[last_pass_dir_ > 0 ? 0 : 1] = time_s - last_pass_s_;
      if (last_pass_dir_ != dir || time_s - last_pass_s_ > params_.window_s) {
        last_pass_dir_ = dir;
        last_pass_s_ = time_s;
        last_pass_speed_mps_ = -1.0;
        farthest_since_pass_m_ = 0.0;
      }
    }
  }
  if (last_pass_dir_ != 0 && y * last_pass_dir_ > farthest_since_pass_m_) farthest_since_pass_m_ = y * last_pass_dir_;
  last_seen_s_ = time_s;
  last_y_ = y;
  track_.push_back({time_s, point.ground_m});
  while (!track_.empty() && track_.front().time_s < time_s - params_.window_s) track_.pop_front();
  // The walking speed of the pass: y(t) fitted to the points near the line since shortly before it.
  if (last_pass_dir_ != 0 && std::abs(y) <= params_.pass_fit_m && time_s - last_pass_s_ <= params_.window_s) {
    double n = 0, st = 0, stt = 0, sy = 0, sty = 0;
    for (const auto& s : track_) {
      if (std::abs(s.ground_m.y) > params_.pass_fit_m || s.time_s < last_pass_s_ - params_.window_s) continue;
      const double t = s.time_s - last_pass_s_;
      n += 1.0;
      st += t;
      stt += t * t;
      sy += s.ground_m.y;
      sty += t * s.ground_m.y;
    }
    const double den = n * stt - st * st;
    if (n >= params_.min_points && den > 1e-9) last_pass_speed_mps_ = last_pass_dir_ * (n * sty - st * sy) / den;
  }
}

CrossingDecision CrossingPolicy::decide(double time_s, bool cautious, std::optional<double> way_ahead_m) const {
  CrossingDecision d;
  if (track_.empty() || time_s - track_.back().time_s > params_.forget_s) {
    d.reason = track_.empty() ? "nothing tracked" : "the track is " + fmt(time_s - track_.back().time_s, 1) + " s old";
    return d;
  }
  if (static_cast<int>(track_.size()) < params_.min_points) {
    d.kind = CrossingDecision::Kind::wait;
    d.reason = "tracking (" + std::to_string(track_.size()) + " points)";
    return d;
  }
  // Least-squares lines x(t), y(t) over the window, evaluated now.
  const double t0 = track_.back().time_s;
  double st = 0, stt = 0, sx = 0, sy = 0, stx = 0, sty = 0;
  const double n = static_cast<double>(track_.size());
  for (const auto& s : track_) {
    const double t = s.time_s - t0;
    st += t;
    stt += t * t;
    sx += s.ground_m.x;
    sy += s.ground_m.y;
    stx += t * s.ground_m.x;
    sty += t * s.ground_m.y;
  }
  const double den = n * stt - st * st;
  double vx = 0.0, vy = 0.0;
  if (den > 1e-9) {
    vx = (n * stx - st * sx) / den;
    vy = (n * sty - st * sy) / den;
  }
  const double mt = st / n;
  const double dt = time_s - t0;
  d.range_m = sx / n + vx * (dt - mt);
  d.lateral_m = sy / n + vy * (dt - mt);
  const double side = d.lateral_m >= 0.0 ? 1.0 : -1.0;
  d.lateral_speed_mps = side * vy;  // d|y|/dt
  const double beyond_m = std::abs(d.lateral_m) - params_.lane_half_width_m;
  const std::string where = "lateral " + fmt(d.lateral_m) + " m, " + fmt(d.range_m) + " m ahead, moving " +
                            fmt(d.lateral_speed_mps) + " m/s " + (d.lateral_speed_mps < 0.0 ? "towards" : "away from") +
                            " the lane";
  if (beyond_m <= 0.0) {
    d.kind = CrossingDecision::Kind::wait;
    d.reason = "in the lane (" + where + ")";
    return d;
  }
  // The time the robot needs to clear the lane (geometry at the crossing speed, or crossing_s).
  const bool geometric = params_.speed_mps > 0.0;
  d.way_ahead_m = way_ahead_m ? *way_ahead_m : std::clamp(d.range_m, 0.0, params_.approach_m);
  d.required_s = geometric ? clear_time_s(params_, d.way_ahead_m) + params_.margin_s : params_.crossing_s;
  const std::string needs =
      geometric ? "the robot needs " + fmt(d.required_s, 1) + " s (" + fmt(clear_distance_m(params_, d.way_ahead_m)) +
                      " m at " + fmt(params_.speed_mps) + " m/s + " + fmt(params_.margin_s, 1) + " s margin)"
                : "the crossing time " + fmt(params_.crossing_s, 1) + " s";
  if (d.lateral_speed_mps < -params_.min_speed_mps) {
    d.arrival_s = beyond_m / -d.lateral_speed_mps;
    d.kind = d.arrival_s < d.required_s ? CrossingDecision::Kind::wait : CrossingDecision::Kind::go;
    d.reason = "arrives in the lane in " + fmt(d.arrival_s, 1) + " s (" +
               (d.kind == CrossingDecision::Kind::wait ? "within" : "after") + " " + needs + "; " + where + ")";
    return d;
  }
  d.kind = beyond_m >= params_.away_clear_m ? CrossingDecision::Kind::go : CrossingDecision::Kind::wait;
  d.reason = std::string(d.kind == CrossingDecision::Kind::go ? "clear of the lane by " : "only ") + fmt(beyond_m) +
             " m beyond the lane's edge (" + where + ")";
  const int dir = d.lateral_m > 0.0 ? 1 : -1;
  if (geometric && d.lateral_speed_mps > params_.min_speed_mps && last_pass_dir_ == dir &&
      last_pass_speed_mps_ > params_.min_speed_mps) {
    // Walking away after a pass it was seen to make: where it is and when it is back in the lane
    // from the pass (its time and speed); the learnt return brings it back to the line, and it
    // enters the lane lane_half_width_m before.
    const double speed = last_pass_speed_mps_;
    const double since_pass_s = time_s - last_pass_s_;
    const double beyond_pass_m = speed * since_pass_s - params_.lane_half_width_m;
    const double back_s = return_after_s(dir);
    const std::string from_pass = "passed the line " + fmt(since_pass_s, 1) + " s ago at " + fmt(speed) + " m/s";
    if (beyond_pass_m < params_.away_clear_m) {
      d.kind = CrossingDecision::Kind::wait;
      d.reason = "walking away, " + fmt(beyond_pass_m) + " m beyond the lane's edge (" + from_pass + "; " + where + ")";
    } else if (back_s < 0.0) {
      d.kind = cautious ? CrossingDecision::Kind::wait : CrossingDecision::Kind::go;
      d.reason = std::string(cautious ? "walking away; waiting to see whether it comes back (" : "walking away (") +
                 from_pass + "; " + where + ")";
    } else {
      d.arrival_s = back_s - since_pass_s - params_.lane_half_width_m / speed;
      d.kind = d.arrival_s < d.required_s ? CrossingDecision::Kind::wait : CrossingDecision::Kind::go;
      d.reason = std::string(d.kind == CrossingDecision::Kind::wait ? "walking away, but it comes back into the lane in "
                                                                    : "walking away, back in the lane in ") +
                 fmt(d.arrival_s, 1) + " s (return " + fmt(back_s, 1) + " s after such a pass, " + from_pass + "; " +
                 needs + "; " + where + ")";
    }
    return d;
  }
  if (d.kind == CrossingDecision::Kind::go && d.lateral_speed_mps > params_.min_speed_mps) {
    // Walking away: does it come back soon? (a person pacing across the way)
    const double back_s = return_after_s(dir);
    if (back_s >= 0.0 && geometric) {
      // No pass seen: it passed at least |y| / speed ago; it enters the lane again
      // lane_half_width_m before it reaches the line, the learnt return after its pass.
      const double speed = std::max(d.lateral_speed_mps, params_.min_speed_mps);
      const double since_pass_s = std::abs(d.lateral_m) / speed;
      d.arrival_s = back_s - since_pass_s - params_.lane_half_width_m / speed;
      if (d.arrival_s < d.required_s) {
        d.kind = CrossingDecision::Kind::wait;
        d.reason = "walking away, but it comes back into the lane in " + fmt(d.arrival_s, 1) + " s (return " +
                   fmt(back_s, 1) + " s after such a pass; " + needs + "; " + where + ")";
      } else {
        d.reason += "; back in the lane in " + fmt(d.arrival_s, 1) + " s (return " + fmt(back_s, 1) + " s), " + needs;
      }
    } else if (back_s >= 0.0 && back_s < params_.crossing_s) {
      d.kind = CrossingDecision::Kind::wait;
      d.reason = "walking away, but it came back " + fmt(back_s, 1) + " s after such a pass (within the crossing time " +
                 fmt(params_.crossing_s, 1) + " s; " + where + ")";
    } else if (back_s < 0.0 && cautious) {
      d.kind = CrossingDecision::Kind::wait;
      d.reason = "walking away; waiting to see whether it comes back (" + where + ")";
    } else if (back_s >= 0.0) {
      d.reason += "; it came back " + fmt(back_s, 1) + " s after such a pass last time";
    }
  }
  return d;
}

void CrossingLanes::add(const Pose2D& robot, const cv::Point2d& ground_m, double time_s) {
  const double c = std::cos(robot.heading_rad), s = std::sin(robot.heading_rad);
  lanes_.push_back({{robot.x_m + c * ground_m.x - s * ground_m.y, robot.y_m + s * ground_m.x + c * ground_m.y}, time_s});
}

std::optional<double> CrossingLanes::ahead_m(const Pose2D& robot, double time_s, double forget_s) {
  const double c = std::cos(robot.heading_rad), s = std::sin(robot.heading_rad);
  auto along = [&](const Lane& l) { return (l.at_m.x - robot.x_m) * c + (l.at_m.y - robot.y_m) * s; };
  std::erase_if(lanes_, [&](const Lane& l) { return along(l) <= 0.0 || time_s - l.time_s > forget_s; });
  std::optional<double> nearest;
  for (const auto& l : lanes_)
    if (!nearest || along(l) < *nearest) nearest = along(l);
  return nearest;
}

}  // namespace visnav::ipt
