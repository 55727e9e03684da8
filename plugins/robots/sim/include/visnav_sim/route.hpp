// visnav simulator — route scripts for reproducible, unattended teaching.
//
// A route file (config/routes/*.yaml, keys in docs/sim.md) holds either
//  * `commands:` a list of {distance_m | duration_s, v, w}: hold (v m/s, w rad/s) until the
//    robot's odometric path length grew by |distance_m| or duration_s of simulated time
//    passed; or
//  * `waypoints:` a list of {x, y, kind} (world metres; kind = primitive of the leg that
//    starts at this waypoint: "feature", "path" or "memory") driven by an internal pure-pursuit
//    controller that behaves like an operator: it updates its command at command_rate_hz,
//    quantises ω, slows down in curves and holds each command in between.
// Optional `start: [x, y, heading_deg]` and `world:`.
//
// Thread-safety: value types; RouteFollower is single-threaded.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/config_node.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::sim {

struct RouteCommand {
  double distance_m = 0.0;  ///< > 0: run for this odometric path length
  double duration_s = 0.0;  ///< > 0: run for this long (exactly one of the two is set)
  Twist twist;
  SourceLocation where;
};

struct RouteWaypoint {
  cv::Point2d position_m;
  std::string kind = "feature";  ///< primitive of the leg starting here
  SourceLocation where;
};

struct PursuitParams {
  double lookahead_m = 1.2;
  double speed_mps = 0.6;
  double min_speed_mps = 0.2;       ///< speed in the sharpest curves
  double max_angular_radps = 0.8;
  double command_rate_hz = 5.0;     ///< how often the "operator" changes the command
  double angular_step_radps = 0.05; ///< ω quantisation
  double goal_tolerance_m = 0.3;
};

struct Route {
  std::string name;
  std::string file;
  std::string world;                 ///< world named by the route ("" = none)
  std::optional<Pose2D> start;       ///< world frame
  std::vector<RouteCommand> commands;
  std::vector<RouteWaypoint> waypoints;
  bool closed = false;               ///< waypoints: drive back to the first waypoint
  PursuitParams pursuit;

  /// Polyline length of the waypoints (including the closing leg), metres.
  [[nodiscard]] double waypoint_length_m() const;
};

[[nodiscard]] Result<Route> load_route(const std::string& path);
[[nodiscard]] Result<Route> parse_route(std::string_view yaml_text, const std::string& file_label);

/// Produces commands for a Route, one call per control tick.
class RouteFollower {
 public:
  explicit RouteFollower(Route route);
  /// Next command given the robot's true pose (the operator sees the world), its odometric
  /// distance and the simulated time; nullopt once the route is complete.
  std::optional<Twist> next(const Pose2D& pose_world, double odom_distance_m, double time_s);
  /// Index of the current leg (command index or waypoint leg) and its kind ("" for commands).
  [[nodiscard]] int leg() const { return leg_; }
  [[nodiscard]] std::string leg_kind() const;
  [[nodiscard]] bool done() const { return done_; }
  [[nodiscard]] const Route& route() const { return route_; }

 private:
  std::optional<Twist> next_command(double odom_distance_m, double time_s);
  std::optional<Twist> next_pursuit(const Pose2D& pose, double time_s);

  Route route_;
  std::vector<cv::Point2d> path_;  // waypoints (+ first again if closed)
  int leg_ = 0;
  bool done_ = false;
  bool started_ = false;
  double leg_start_distance_m_ = 0.0;
  double leg_start_time_s_ = 0.0;
  double next_update_s_ = 0.0;
  Twist held_;
};

}  // namespace visnav::sim
