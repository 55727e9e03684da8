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
          .range(2, 1000);
  return s;
}

void CrossingPolicy::observe(double time_s, const MovingPoint& point) {
  const double y = point.ground_m.y;
  if (last_seen_s_ >= 0.0 && time_s - last_seen_s_ <= params_.window_s && ((last_y_ < 0.0) != (y < 0.0))) {
    const int dir = y > last_y_ ? 1 : -1;  // a pass: it walked across the robot's line
    if (last_pass_dir_ == -dir) return_after_s_[last_pass_dir_ > 0 ? 0 : 1] = time_s - last_pass_s_;
    if (last_pass_dir_ != dir || time_s - last_pass_s_ > params_.window_s) {
      last_pass_dir_ = dir;
      last_pass_s_ = time_s;
    }
  }
  last_seen_s_ = time_s;
  last_y_ = y;
  track_.push_back({time_s, point.ground_m});
  while (!track_.empty() && track_.front().time_s < time_s - params_.window_s) track_.pop_front();
}

CrossingDecision CrossingPolicy::decide(double time_s, bool cautious) const {
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
  if (d.lateral_speed_mps < -params_.min_speed_mps) {
    d.arrival_s = beyond_m / -d.lateral_speed_mps;
    d.kind = d.arrival_s < params_.crossing_s ? CrossingDecision::Kind::wait : CrossingDecision::Kind::go;
    d.reason = "arrives in the lane in " + fmt(d.arrival_s, 1) + " s (" +
               (d.kind == CrossingDecision::Kind::wait ? "within" : "after") + " the crossing time " +
               fmt(params_.crossing_s, 1) + " s; " + where + ")";
    return d;
  }
  d.kind = beyond_m >= params_.away_clear_m ? CrossingDecision::Kind::go : CrossingDecision::Kind::wait;
  d.reason = std::string(d.kind == CrossingDecision::Kind::go ? "clear of the lane by " : "only ") + fmt(beyond_m) +
             " m beyond the lane's edge (" + where + ")";
  if (d.kind == CrossingDecision::Kind::go && d.lateral_speed_mps > params_.min_speed_mps) {
    // Walking away: does it come back soon? (a person pacing across the way)
    const int dir = d.lateral_m > 0.0 ? 1 : -1;
    const double back_s = return_after_s(dir);
    if (back_s >= 0.0 && back_s < params_.crossing_s) {
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
