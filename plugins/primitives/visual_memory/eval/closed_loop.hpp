// visnav visual memory — the closed-loop rig shared by the closed-loop tests and
// `visual_memory_lateral` (docs/visual_memory.md): the straight15m world, RobotCore + CameraCore
// with the error models of config/sim_experiment.yaml (odometry scale N(0, 3 %), wheel asymmetry
// N(0, 0.2 %), heading drift N(0, 0.05 deg/m), distance and heading noise, slip on gravel and
// grass, 50 ms actuation delay; camera noise 3 levels, exposure flicker 6 %, 10 ms motion blur,
// 50 ms latency, 3 % dropped frames), 320×240, 10 Hz lock-step, core only (no behaviour tree):
// the teach and each replay draw their own errors from their seed.
// Not part of the plugin: header-only, used by executables that link visnav_sim.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include "visnav/result.hpp"
#include "visnav/visual_memory/follower.hpp"
#include "visnav/visual_memory/teacher.hpp"
#include "visnav_sim/camera.hpp"
#include "visnav_sim/robot.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::visual_memory::eval {

inline constexpr double kRigDt = 0.1;  ///< s, 10 Hz lock-step

inline sim::RobotParams rig_robot_params(int seed) {
  sim::RobotParams p;
  p.seed = seed;
  p.odom_rate_hz = 50;
  p.actuation_delay_s = 0.05;
  p.odom_scale_error_sd_pct = 3;
  p.odom_wheel_asymmetry_sd_pct = 0.2;
  p.track_width_m = 0.4;
  p.odom_heading_drift_sd_degpm = 0.05;
  p.odom_distance_noise_m_per_sqrt_m = 0.01;
  p.odom_heading_noise_deg_per_sqrt_m = 0.5;
  p.slip_path_pct = 3;
  p.slip_grass_pct = 5;
  p.slip_other_pct = 0.5;
  return p;
}

inline sim::CameraParams rig_camera_params(int seed) {
  sim::CameraParams c;
  c.seed = seed;
  c.noise_std = 3;
  c.exposure_jitter = 0.06;
  c.exposure_time_constant_s = 3;
  c.motion_blur_exposure_s = 0.01;
  c.latency_s = 0.05;
  c.drop_probability = 0.03;
  return c;
}

/// The straight15m world (gravel path along +x; wall left, fence right, trees, a facade ahead).
inline Result<std::shared_ptr<const sim::World>> rig_world(const std::string& source_dir) {
  return sim::load_world_cached(source_dir + "/config/worlds/straight15m.yaml");
}

struct Rig {
  std::shared_ptr<sim::RobotCore> robot;
  std::unique_ptr<sim::CameraCore> camera;
  Rig(std::shared_ptr<const sim::World> world, int seed, const Pose2D& start)
      : robot(std::make_shared<sim::RobotCore>(rig_robot_params(seed), start, world)),
        camera(std::make_unique<sim::CameraCore>(rig_camera_params(seed), robot, world)) {}
};

/// Teaches `length_m` along y = 0 from the origin, the "operator" steering on the ground truth.
inline Result<VisualMemory> rig_teach(std::shared_ptr<const sim::World> world, int seed, double length_m) {
  Rig rig(std::move(world), seed, Pose2D{0.0, 0.0, 0.0});
  VISNAV_ASSIGN(MemoryTeacher teacher, MemoryTeacher::create(TeachParams{}));
  for (int i = 0; i < 4000; ++i) {
    const Pose2D p = rig.robot->ground_truth();
    if (rig.robot->odometry().distance_m >= length_m) break;
    rig.robot->command({0.3, -1.5 * p.heading_rad - 0.8 * p.y_m});
    VISNAV_TRY(rig.robot->step(kRigDt));
    if (auto frame = rig.camera->grab()) {
      VISNAV_TRY(teacher.add_frame(frame->image, rig.robot->odometry(), rig.robot->odometry().distance_m));
    }
  }
  return teacher.finish();
}

struct RigOutcome {
  bool goal = false;
  bool failed = false;
  std::string failure;
  Pose2D end;
  double max_abs_y = 0.0;
  double y_at_half_m = 0.0;     ///< lateral offset when half the edge was driven (true x)
  int lost_frames = 0;
  int relocalised = 0;
  int resumed = 0;
  bool moved_while_lost = false;
  bool nonfinite_command = false;
  /// The follower's lateral estimate (FollowStep::lateral_m) against the truth, over the frames
  /// with a pose: mean and RMS of estimate − true (m). The taught line is y = 0, heading 0, so
  /// the camera's true lateral position in a reference's frame (right positive) is −y.
  double lateral_error_mean_m = 0.0;
  double lateral_error_rms_m = 0.0;
  int pose_frames = 0;
  bool ended_by_odometry = false;
};

/// Replays `memory` from `start`; `occlude(t_s, image)` may paint over the frame; `on_frame`
/// sees every step with the true pose.
inline Result<RigOutcome> rig_replay(std::shared_ptr<const sim::World> world, const VisualMemory& memory,
                                     const ReplayParams& params, int seed, const Pose2D& start,
                                     const std::function<void(double, cv::Mat&)>& occlude = {},
                                     const std::function<void(const FollowStep&, const Pose2D&)>& on_frame = {}) {
  Rig rig(std::move(world), seed, start);
  const double length_m = memory.references.back().distance_m;
  VISNAV_ASSIGN(MemoryFollower follower, MemoryFollower::create(params, memory, length_m));
  RigOutcome out;
  bool half_seen = false;
  Twist command;
  for (int i = 0; i < 2400; ++i) {
    rig.robot->command(command);
    VISNAV_TRY(rig.robot->step(kRigDt));
    auto frame = rig.camera->grab();
    if (!frame) continue;  // dropped: the last command holds
    cv::Mat image = frame->image.clone();
    if (occlude) occlude(rig.robot->time_s(), image);
    const FollowStep s = follower.step(image, rig.robot->odometry().distance_m);
    if (!std::isfinite(s.command.linear_mps) || !std::isfinite(s.command.angular_radps)) out.nonfinite_command = true;
    command = s.command;
    const Pose2D truth = rig.robot->ground_truth();
    if (on_frame) on_frame(s, truth);
    out.max_abs_y = std::max(out.max_abs_y, std::abs(truth.y_m));
    if (!half_seen && truth.x_m >= 0.5 * length_m) {
      out.y_at_half_m = truth.y_m;
      half_seen = true;
    }
    if (s.pose_ok) {
      const double e = s.lateral_m - (-truth.y_m);
      out.lateral_error_mean_m += e;
      out.lateral_error_rms_m += e * e;
      ++out.pose_frames;
    }
    out.resumed += s.resumed;
    if (s.status == FollowStatus::lost) {
      ++out.lost_frames;
      if (s.command.linear_mps != 0.0 || s.command.angular_radps != 0.0) out.moved_while_lost = true;
    }
    if (s.status == FollowStatus::relocalised) ++out.relocalised;
    if (s.status == FollowStatus::failed) {
      out.failed = true;
      out.failure = s.failure;
      break;
    }
    if (s.finished()) {
      out.goal = s.status == FollowStatus::goal;
      out.ended_by_odometry = s.status == FollowStatus::goal_by_odometry;
      break;
    }
  }
  if (out.pose_frames > 0) {
    out.lateral_error_mean_m /= out.pose_frames;
    out.lateral_error_rms_m = std::sqrt(out.lateral_error_rms_m / out.pose_frames);
  }
  out.end = rig.robot->ground_truth();
  return out;
}

}  // namespace visnav::visual_memory::eval
