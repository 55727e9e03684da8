// visnav simulator — the `visnav sim ...` subcommands (contributed by the simulator plugin
// through its CommandEntry; callable directly from tests).
//
//   visnav sim snapshot --world W --pose x,y,theta_deg -o view.png [--width N --height N
//                       --hfov DEG --cam-height M --pitch DEG --season S --shadows S --labels L.png --label-ids I.png]
//   visnav sim topview  --world W [--route R] -o top.png [--px-per-m N]
//   visnav sim drive    --world W --route R -o traj.csv [--rate HZ --max-time S
//                       --robot-param key=value ...]
//   visnav sim teleop   --world W [-o traj.csv --record route.yaml --view view.png]
// Every subcommand accepts --help. Exit status 0 on success, 1 on errors (printed to `err`),
// 2 on usage errors.
//
// Thread-safety: not thread-safe (teleop changes terminal modes).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "visnav/result.hpp"
#include "visnav_sim/robot.hpp"
#include "visnav_sim/route.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {

/// `args` excludes "sim" (args[0] is the subcommand).
int sim_main(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// Samples of a drive: one row per control tick.
struct DriveSample {
  double time_s = 0.0;
  Pose2D ground_truth;
  Odometry odometry;
  Twist command;
  int leg = 0;
  std::string kind;
};

/// Drives `route` with a robot in `world` at `rate_hz` until the route completes or
/// `max_time_s` passes. Returns one sample per tick.
[[nodiscard]] Result<std::vector<DriveSample>> drive_route(const Route& route, RobotParams robot_params,
                                                           double rate_hz, double max_time_s);
/// Writes samples as CSV (header: time_s,gt_x_m,gt_y_m,gt_heading_rad,odom_x_m,odom_y_m,
/// odom_heading_rad,odom_distance_m,cmd_linear_mps,cmd_angular_radps,leg,kind).
[[nodiscard]] Status write_drive_csv(const std::vector<DriveSample>& samples, const std::string& path);

/// Keyboard teleop state: the held command and whether the user asked to quit.
struct TeleopState {
  Twist command;
  bool quit = false;
};
/// Applies one key (a character, or an escape sequence "\x1b[A".."\x1b[D" for the arrows):
/// up/w +0.1 m/s, down/s -0.1 m/s, left/a +0.1 rad/s, right/d -0.1 rad/s, space stop, q quit.
void apply_teleop_key(TeleopState& state, const std::string& key);

/// Top view of a world (BGR) with an optional route, at `px_per_m` (0 = fit into 1200 px).
[[nodiscard]] cv::Mat render_topview(const World& world, const Route* route, double px_per_m);

}  // namespace visnav::sim
