// visnav simulator — robot kinematics, odometry model and the `sim` robot object.
//
// Kinematics (world frame, see visnav/types.hpp):
//  * diff_drive: unicycle, v and ω as commanded (within limits).
//  * car_like:   bicycle; |ω| <= |v| / min_turning_radius_m (a car cannot turn on the spot).
//  * tracked:    unicycle whose yaw rate is reduced by skid: ω_true = (1 - track_slip) * ω.
// Commands pass an actuation delay (actuation_delay_s, FIFO), are clamped to the velocity
// limits and reached with the acceleration limits. Without a command for command_timeout_s
// of simulated time the target velocity becomes zero (watchdog). Motion is integrated in
// sub-steps of at most integration_step_s with the exact arc of each sub-step.
//
// Per-run error draw: when the robot is created, and again whenever `seed` changes on
// reconfigure (an experiment gives the teach run and each replay run their own seed), the
// run's systematic errors are drawn once from the configured distributions:
//   scale s = odom_scale_error_pct + N(0, odom_scale_error_sd_pct²)            [%]
//   wheel asymmetry a = odom_wheel_asymmetry_pct + N(0, odom_wheel_asymmetry_sd_pct²) [%]
//   drift δ = odom_heading_drift_degpm + N(0, odom_heading_drift_sd_degpm²)    [deg/m]
// With every *_sd_* at 0 the run errors are the configured values (a deterministic robot).
//
// Slip: on the ground class under the robot (World::ground_label_at) the body moves
// (1 − slip) of what the wheels roll: slip_path_pct on paths, slip_grass_pct on grass,
// slip_other_pct elsewhere. The wheels (and so the odometry) do not see it.
//
// Odometry (odom frame: starts at (0, 0, 0) wherever the robot starts): each sub-step's wheel
// increment ds_w = ds / (1 − slip) and measured yaw dθ_w (diff-drive and car-like: the true
// yaw; tracked: the commanded yaw, skid is invisible) are measured as
//   ds' = ds_w (1 + s/100) + N(0, σ_d² |ds_w|),
//   dθ' = dθ_w + (a/100)·ds_w / track_width_m + δ·|ds_w| + N(0, σ_θ² |ds_w|)
// (a right wheel a % larger than the left one reads a left turn of a/track_width rad per metre),
// σ_d = odom_distance_noise_m_per_sqrt_m, σ_θ = odom_heading_noise_deg_per_sqrt_m; the odometry
// pose integrates ds', dθ'.
//
// Collisions (body_radius_m > 0): the body is a disc. A sub-step that would bring it closer
// than body_radius_m to a wall whose base is below body_height_m (walls, fences, facades,
// posts), or to a tree's trunk (a disc of trunk_radius_m at the tree's centre), is not taken:
// the robot stops there (velocity zero) and the contact is recorded (collisions()); motion
// away from the obstacle is still possible. One contact is recorded per obstacle until the
// body is clear of it again. Moving obstacles (World::movers) are placed at the sub-step's
// time; one that comes closer than body_radius_m is a collision whether the robot or the
// obstacle moved (a person walking into a standing robot counts); the robot is stopped only by
// its own motion towards it (the obstacle passes through the disc: it does not push).
// A reading is published at t = 0 and then every 1/odom_rate_hz of simulated time (at the
// end of the step that crosses the publication time; its timestamp is that step's time).
// Odometry.distance_m is the signed measured path length.
//
// Compute freezes (seed 002 Table 1 lists platforms whose computer froze for seconds): with
// freeze_rate_per_min > 0, each step(dt) starts a freeze with probability 1 − exp(−rate·dt/60);
// a freeze lasts U(freeze_min_s, freeze_max_s) and is simulated inside that step, so the caller
// (the run loop in lockstep) sees simulated time jump: no tick, frame or command happens during
// it, and the robot keeps executing the last command until the watchdog (command_timeout_s)
// stops it — what a stalled navigation computer does to a real base. The draws come from a
// generator of their own (seeded like the run errors), so switching freezes on does not change
// the odometry noise of the run.
//
// Ground truth is only exposed through SimulationControl (and RobotCore for evaluation code).
//
// Thread-safety: RobotCore is internally locked; every method may be called from any thread.
// SimRobot forwards to its core.
#pragma once

#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/params.hpp"
#include "visnav/types.hpp"
#include "visnav_sim/movers.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {

struct RobotParams {
  std::string world;         ///< world file or name (config/worlds/<name>.yaml); "" = none (camera brings its own)
  std::string obstacles;     ///< obstacle file added to the world (per-run placement); "" = none
  std::string kinematics = "diff_drive";
  double max_linear_mps = 1.0;
  double max_reverse_mps = 0.5;
  double max_angular_radps = 1.5;
  double linear_accel_mps2 = 1.0;
  double angular_accel_radps2 = 3.0;
  double min_turning_radius_m = 1.0;  ///< car_like only
  double track_slip = 0.1;            ///< tracked only, in [0, 0.9]
  double actuation_delay_s = 0.0;
  double command_timeout_s = 0.5;     ///< watchdog; 0 disables it
  double integration_step_s = 0.01;
  std::vector<double> start_pose;     ///< x_m;y_m;heading_deg; empty = the world's start
  double displacement_lateral_m = 0.0;       ///< added to the start pose, in its frame (left +)
  double displacement_longitudinal_m = 0.0;  ///< forward +
  double displacement_heading_deg = 0.0;     ///< counter-clockwise +
  double odom_rate_hz = 50.0;
  double odom_scale_error_pct = 0.0;
  double odom_heading_drift_degpm = 0.0;
  double odom_distance_noise_m_per_sqrt_m = 0.0;
  double odom_heading_noise_deg_per_sqrt_m = 0.0;
  double odom_scale_error_sd_pct = 0.0;       ///< per-run draw, see the file comment
  double odom_wheel_asymmetry_pct = 0.0;      ///< right wheel larger than the left, %
  double odom_wheel_asymmetry_sd_pct = 0.0;
  double odom_heading_drift_sd_degpm = 0.0;
  double track_width_m = 0.4;                 ///< wheel separation for the asymmetry model
  double slip_path_pct = 0.0;                 ///< wheel slip on paths (gravel), %
  double slip_grass_pct = 0.0;
  double slip_other_pct = 0.0;                ///< pavement, floor, other ground
  double body_radius_m = 0.0;                 ///< collision disc; 0 = no collisions
  double body_height_m = 0.6;                 ///< walls whose base is higher are passed under
  double trunk_radius_m = 0.25;               ///< tree trunks as discs
  double freeze_rate_per_min = 0.0;           ///< compute freezes per minute of simulated time; 0 = none
  double freeze_min_s = 1.0;                  ///< shortest freeze, s
  double freeze_max_s = 3.0;                  ///< longest freeze, s
  int seed = 1;
  double pose_history_s = 5.0;        ///< how far back pose_at() can look (camera latency)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<RobotParams>& schema();
};

/// The systematic odometry errors of one run (drawn from RobotParams, see the file comment).
struct RunErrors {
  double scale_error_pct = 0.0;
  double wheel_asymmetry_pct = 0.0;
  double heading_drift_degpm = 0.0;
};
/// Draws a run's errors from `params` with its seed (deterministic).
[[nodiscard]] RunErrors draw_run_errors(const RobotParams& params);

/// An obstacle of the collision model: a segment (radius 0) or a disc (from == to).
struct CollisionShape {
  cv::Point2d from;
  cv::Point2d to;
  double radius_m = 0.0;
  std::string name;
  int mover = -1;  ///< World::movers index of a moving obstacle (shape displaced by its offset_at(t)), else -1
};
/// The collision shapes of a world for a body of `body_height_m`.
[[nodiscard]] std::vector<CollisionShape> collision_shapes(const World& world, double body_height_m,
                                                           double trunk_radius_m);

/// Kinematics + odometry state machine. Pure simulation, no I/O.
class RobotCore {
 public:
  /// `start_world` is the pose before the displacement is applied (use resolve_start()).
  RobotCore(RobotParams params, Pose2D start_world, std::shared_ptr<const World> world);

  Status step(double dt_s);
  void command(const Twist& twist);
  [[nodiscard]] double time_s() const;
  [[nodiscard]] Pose2D ground_truth() const;
  /// True pose at an earlier simulated time (linear interpolation over the pose history;
  /// clamped to the oldest/newest sample).
  [[nodiscard]] Pose2D pose_at(double time_s) const;
  void teleport(const Pose2D& pose_world);
  /// Latest published odometry reading (always present: one is published at t = 0).
  [[nodiscard]] Odometry odometry() const;
  /// Current velocity of the body (true).
  [[nodiscard]] Twist true_twist() const;
  /// True path length travelled (signed).
  [[nodiscard]] double true_distance_m() const;
  /// Copy of the parameters in use.
  [[nodiscard]] RobotParams params() const;
  /// Replaces limits, delays and odometry settings (live reconfiguration); the name, world,
  /// kinematics and start settings are ignored.
  void set_params(const RobotParams& params);
  /// The systematic errors drawn for the current run.
  [[nodiscard]] RunErrors run_errors() const;
  /// Every collision so far (see the file comment).
  [[nodiscard]] std::vector<SimCollision> collisions() const;
  /// Compute freezes simulated so far, and their total length in seconds (see the file comment).
  [[nodiscard]] int freeze_count() const;
  [[nodiscard]] double frozen_s() const;
  /// World the robot drives in (may be null).
  [[nodiscard]] std::shared_ptr<const World> world() const {
    std::lock_guard lock(mutex_);
    return world_;
  }
  /// Replaces the world (a replay with obstacles placed per run: the same world plus an obstacle
  /// file); the collision shapes are rebuilt, contacts restarted at the current pose.
  void set_world(std::shared_ptr<const World> world);
  /// Displacement of moving obstacle `mover` of `world` at simulated time `time_s`, as the
  /// collision check places it (yielding walkers: MoverStates, movers.hpp). The renderer of the
  /// run's sim camera asks here so that renders and collisions agree; a `world` other than the
  /// robot's gets its blind motion.
  [[nodiscard]] cv::Point2d mover_offset(const World* world, int mover, double time_s) const;

 private:
  void substep_locked(double dt_s);
  /// Displacement of collision shape i at simulated time t (moving obstacles; else zero).
  [[nodiscard]] cv::Point2d shape_offset(std::size_t i, double time_s) const {
    const int m = shapes_[i].mover;
    return m < 0 ? cv::Point2d(0, 0) : movers_.offset_at(m, time_s);
  }
  void publish_locked();

  mutable std::mutex mutex_;
  RobotParams params_;
  std::shared_ptr<const World> world_;
  double time_s_ = 0.0;
  Pose2D pose_;
  Twist velocity_;          // current true body velocity (before track slip)
  Twist target_;            // active (delayed) command
  double last_command_s_ = 0.0;
  bool commanded_ = false;
  std::deque<std::pair<double, Twist>> pending_;  // (time it takes effect, command)
  double true_distance_m_ = 0.0;
  Pose2D odom_pose_;
  double odom_distance_m_ = 0.0;
  double odom_window_distance_m_ = 0.0;  // measured distance since the last publication
  double odom_window_heading_rad_ = 0.0;
  double last_publish_s_ = 0.0;
  double next_publish_s_ = 0.0;
  Odometry published_;
  std::mt19937_64 rng_;
  std::mt19937_64 freeze_rng_;
  int freeze_count_ = 0;
  double frozen_s_ = 0.0;
  std::deque<std::pair<double, Pose2D>> history_;
  RunErrors run_errors_;
  std::vector<CollisionShape> shapes_;
  std::vector<char> in_contact_;  // per shape: body currently touching it
  std::vector<SimCollision> collisions_;
  MoverStates movers_;  // where the moving obstacles are (yielding walkers depend on the robot)
};

/// Start pose of a robot: params.start_pose (or the world's start, or the origin) with the
/// displacement applied in the start pose's frame.
[[nodiscard]] Pose2D resolve_start(const RobotParams& params, const World* world);

/// The `sim` robot plugin object. The `sim` camera of the same run finds it through
/// HostServices::robot() and shares its core.
class SimRobot final : public Robot, public SimulationControl {
 public:
  using Params = RobotParams;
  /// `params` is the `params:` block; relative `world` paths resolve against its file.
  /// Every problem create() would find in a params block, without building anything: the
  /// schema, validate() and the `world` file (resolved against the block's file, opened and
  /// parsed; errors at the key 'world'). create() runs the same checks first.
  static std::vector<Error> check_params(const ConfigNode& params);
  static Result<std::unique_ptr<SimRobot>> create(const ConfigNode& params, HostServices& host);
  static Result<std::unique_ptr<SimRobot>> create(const RobotParams& params, const std::string& relative_to = {});
  ~SimRobot() override;
  SimRobot(const SimRobot&) = delete;
  SimRobot& operator=(const SimRobot&) = delete;

  Status send_command(const Twist& command) override;
  std::optional<Odometry> latest_odometry() override;
  SimulationControl* simulation() override { return this; }
  Status reconfigure(const ConfigNode& params) override;

  Status step(double dt_s) override;
  [[nodiscard]] double time_s() const override;
  [[nodiscard]] Pose2D ground_truth_pose() const override;
  Status set_ground_truth_pose(const Pose2D& pose_world) override;
  [[nodiscard]] std::vector<SimCollision> collisions() const override;

  [[nodiscard]] const std::shared_ptr<RobotCore>& core() const { return core_; }

 private:
  explicit SimRobot(std::shared_ptr<RobotCore> core);
  std::shared_ptr<RobotCore> core_;
  Logger* logger_ = nullptr;        // the run's logger (create(ConfigNode, host)): collisions are logged
  std::size_t collisions_logged_ = 0;
};

}  // namespace visnav::sim
