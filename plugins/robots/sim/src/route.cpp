// Route scripts: command lists and waypoint routes driven by an operator-like pure pursuit.
#include "visnav_sim/route.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "visnav_sim/world.hpp"
#include "yaml_util.hpp"
#include "visnav/file_io.hpp"

namespace visnav::sim {
using namespace detail;

namespace {

Status parse_pursuit(const ConfigNode& n, PursuitParams& p) {
  VISNAV_TRY(check_keys(n, {"lookahead_m", "speed_mps", "min_speed_mps", "max_angular_radps", "command_rate_hz",
                            "angular_step_radps", "goal_tolerance_m"},
                        "'pursuit'"));
  VISNAV_ASSIGN(p.lookahead_m, get_double(n, "lookahead_m", p.lookahead_m, 0.1, 100));
  VISNAV_ASSIGN(p.speed_mps, get_double(n, "speed_mps", p.speed_mps, 0.01, 20));
  VISNAV_ASSIGN(p.min_speed_mps, get_double(n, "min_speed_mps", p.min_speed_mps, 0.0, 20));
  VISNAV_ASSIGN(p.max_angular_radps, get_double(n, "max_angular_radps", p.max_angular_radps, 0.01, 20));
  VISNAV_ASSIGN(p.command_rate_hz, get_double(n, "command_rate_hz", p.command_rate_hz, 0.1, 1000));
  VISNAV_ASSIGN(p.angular_step_radps, get_double(n, "angular_step_radps", p.angular_step_radps, 0.0, 5));
  VISNAV_ASSIGN(p.goal_tolerance_m, get_double(n, "goal_tolerance_m", p.goal_tolerance_m, 0.01, 100));
  return ok();
}

}  // namespace

double Route::waypoint_length_m() const {
  double len = 0.0;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) len += cv::norm(waypoints[i + 1].position_m - waypoints[i].position_m);
  if (closed && waypoints.size() > 1) len += cv::norm(waypoints.front().position_m - waypoints.back().position_m);
  return len;
}

Result<Route> parse_route(std::string_view yaml_text, const std::string& file_label) {
  VISNAV_ASSIGN(ConfigNode doc, parse_yaml_text(yaml_text, file_label));
  if (!doc.is_map() || doc.find("route") == nullptr)
    return node_error(doc, "a route file has one top-level key 'route'", ErrorCode::missing, "route");
  VISNAV_TRY(check_keys(doc, {"route"}, "the route file"));
  const ConfigNode& root = *doc.find("route");
  VISNAV_TRY(check_keys(root, {"name", "world", "start", "closed", "pursuit", "waypoints", "commands"}, "'route'"));
  Route route;
  route.file = file_label;
  VISNAV_ASSIGN(route.name, get_string(root, "name", std::filesystem::path(file_label).stem().string()));
  VISNAV_ASSIGN(route.world, get_string(root, "world", ""));
  VISNAV_ASSIGN(route.closed, get_bool(root, "closed", false));
  if (const ConfigNode* s = root.find("start")) {
    VISNAV_ASSIGN(auto v, as_numbers(*s, "start", 3));
    route.start = Pose2D{v[0], v[1], v[2] * CV_PI / 180.0};
  }
  if (const ConfigNode* p = root.find("pursuit")) VISNAV_TRY(parse_pursuit(*p, route.pursuit));
  const ConfigNode* wps = root.find("waypoints");
  const ConfigNode* cmds = root.find("commands");
  if ((wps == nullptr) == (cmds == nullptr)) return node_error(root, "'route' needs exactly one of 'waypoints' or 'commands'");
  if (cmds != nullptr) {
    if (!cmds->is_sequence() || cmds->items().empty()) return node_error(*cmds, "key 'commands': expected a non-empty list");
    int i = 0;
    for (const auto& c : cmds->items()) {
      const std::string what = "command " + std::to_string(i++);
      VISNAV_TRY(check_keys(c, {"distance_m", "duration_s", "v", "w"}, what));
      RouteCommand rc;
      rc.where = c.where();
      const bool has_d = c.find("distance_m") != nullptr, has_t = c.find("duration_s") != nullptr;
      if (has_d == has_t) return node_error(c, what + ": give exactly one of 'distance_m' or 'duration_s'");
      VISNAV_ASSIGN(rc.distance_m, get_double(c, "distance_m", 0.0, 0.0, 1e6));
      VISNAV_ASSIGN(rc.duration_s, get_double(c, "duration_s", 0.0, 0.0, 1e6));
      if (has_d && rc.distance_m <= 0.0) return node_error(*c.find("distance_m"), what + ": distance_m must be > 0");
      if (has_t && rc.duration_s <= 0.0) return node_error(*c.find("duration_s"), what + ": duration_s must be > 0");
      VISNAV_ASSIGN(rc.twist.linear_mps, get_double(c, "v", 0.0, -20, 20));
      VISNAV_ASSIGN(rc.twist.angular_radps, get_double(c, "w", 0.0, -20, 20));
      if (has_d && rc.twist.linear_mps == 0.0)
        return node_error(c, what + ": a distance_m command needs v != 0 (the robot would never get there)");
      route.commands.push_back(rc);
    }
  } else {
    if (!wps->is_sequence() || wps->items().size() < 2) return node_error(*wps, "key 'waypoints': expected at least 2 waypoints");
    std::string kind = "feature";
    int i = 0;
    for (const auto& w : wps->items()) {
      const std::string what = "waypoint " + std::to_string(i++);
      RouteWaypoint rw;
      rw.where = w.where();
      if (w.is_sequence()) {
        VISNAV_ASSIGN(rw.position_m, as_point(w, "waypoints"));
      } else {
        VISNAV_TRY(check_keys(w, {"at", "kind"}, what));
        const ConfigNode* at = w.find("at");
        if (at == nullptr) return node_error(w, what + ": missing key 'at'", ErrorCode::missing, "at");
        VISNAV_ASSIGN(rw.position_m, as_point(*at, "at"));
        VISNAV_ASSIGN(kind, get_string(w, "kind", kind));
        if (kind != "feature" && kind != "path" && kind != "memory")
          return node_error(*w.find("kind"), what + ": kind '" + kind + "' is not one of: feature, path, memory",
                            ErrorCode::out_of_range, "kind");
      }
      rw.kind = kind;
      if (!route.waypoints.empty() && cv::norm(rw.position_m - route.waypoints.back().position_m) < 1e-6)
        return node_error(w, what + ": repeats the previous waypoint");
      route.waypoints.push_back(rw);
    }
  }
  return route;
}

Result<Route> load_route(const std::string& path) {
  VISNAV_ASSIGN(const std::string text, visnav::read_text_file(path, visnav::kMaxConfigFileBytes, "route"));
  return parse_route(text, path);
}

RouteFollower::RouteFollower(Route route) : route_(std::move(route)) {
  for (const auto& w : route_.waypoints) path_.push_back(w.position_m);
  if (route_.closed && path_.size() > 1) path_.push_back(path_.front());
}

std::string RouteFollower::leg_kind() const {
  if (route_.waypoints.empty()) return "";
  return route_.waypoints[std::min(static_cast<size_t>(leg_), route_.waypoints.size() - 1)].kind;
}

std::optional<Twist> RouteFollower::next(const Pose2D& pose_world, double odom_distance_m, double time_s) {
  if (done_) return std::nullopt;
  auto cmd = route_.commands.empty() ? next_pursuit(pose_world, time_s) : next_command(odom_distance_m, time_s);
  if (!cmd) done_ = true;
  return cmd;
}

std::optional<Twist> RouteFollower::next_command(double odom_distance_m, double time_s) {
  while (leg_ < static_cast<int>(route_.commands.size())) {
    const RouteCommand& c = route_.commands[static_cast<size_t>(leg_)];
    if (!started_) {
      started_ = true;
      leg_start_distance_m_ = odom_distance_m;
      leg_start_time_s_ = time_s;
    }
    const bool finished = c.distance_m > 0.0 ? std::abs(odom_distance_m - leg_start_distance_m_) >= c.distance_m - 1e-9
                                             : time_s - leg_start_time_s_ >= c.duration_s - 1e-9;
    if (!finished) return c.twist;
    ++leg_;
    started_ = false;
  }
  return std::nullopt;
}

std::optional<Twist> RouteFollower::next_pursuit(const Pose2D& pose, double time_s) {
  const PursuitParams& pp = route_.pursuit;
  const cv::Point2d p(pose.x_m, pose.y_m);
  const int last_leg = static_cast<int>(path_.size()) - 2;
  // advance the leg when the robot is past the end of the current one or close to its end
  while (leg_ < last_leg) {
    const cv::Point2d a = path_[static_cast<size_t>(leg_)], b = path_[static_cast<size_t>(leg_) + 1];
    const cv::Point2d ab = b - a;
    const double t = (p - a).dot(ab) / ab.dot(ab);
    if (t >= 1.0 || cv::norm(b - p) < pp.lookahead_m * 0.5) ++leg_;
    else break;
  }
  const cv::Point2d goal = path_.back();
  if (leg_ >= last_leg && cv::norm(goal - p) < pp.goal_tolerance_m) return std::nullopt;
  // lookahead point: project on the current leg, walk lookahead_m along the path
  const cv::Point2d a = path_[static_cast<size_t>(leg_)], b = path_[static_cast<size_t>(leg_) + 1];
  const cv::Point2d ab = b - a;
  double t = std::clamp((p - a).dot(ab) / ab.dot(ab), 0.0, 1.0);
  double remaining = pp.lookahead_m;
  cv::Point2d target = a + ab * t;
  size_t seg = static_cast<size_t>(leg_);
  while (remaining > 0.0) {
    const cv::Point2d end = path_[seg + 1];
    const double d = cv::norm(end - target);
    if (d >= remaining) { target += (end - target) * (remaining / d); break; }
    remaining -= d;
    target = end;
    if (seg + 2 >= path_.size()) break;
    ++seg;
  }
  if (started_ && time_s + 1e-9 < next_update_s_) return held_;
  started_ = true;
  next_update_s_ = time_s + 1.0 / pp.command_rate_hz;
  const double c = std::cos(pose.heading_rad), s = std::sin(pose.heading_rad);
  const cv::Point2d d = target - p;
  const double lx = c * d.x + s * d.y, ly = -s * d.x + c * d.y;
  const double alpha = std::atan2(ly, lx);
  const double ld = std::max(1e-3, std::hypot(lx, ly));
  Twist cmd;
  if (std::abs(alpha) > 1.2) {  // the operator turns on the spot towards the path
    cmd.linear_mps = 0.0;
    cmd.angular_radps = std::copysign(pp.max_angular_radps * 0.6, alpha);
  } else {
    const double kappa = 2.0 * std::sin(alpha) / ld;
    double v = std::max(pp.min_speed_mps, pp.speed_mps / (1.0 + 1.5 * std::abs(kappa)));
    v = std::min(v, std::max(pp.min_speed_mps * 0.5, cv::norm(goal - p)));  // slow down at the goal
    cmd.linear_mps = v;
    cmd.angular_radps = std::clamp(kappa * v, -pp.max_angular_radps, pp.max_angular_radps);
  }
  if (pp.angular_step_radps > 0.0)
    cmd.angular_radps = std::round(cmd.angular_radps / pp.angular_step_radps) * pp.angular_step_radps;
  held_ = cmd;
  return cmd;
}

}  // namespace visnav::sim
