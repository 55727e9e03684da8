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
// Odometry (odom frame: starts at (0, 0, 0) wherever the robot starts): each sub-step's true
// increment ds, dθ is measured as ds' = ds (1 + odom_scale_error_pct/100) + N(0, σ_d² |ds|),
// dθ' = dθ + drift·|ds| + N(0, σ_θ² |ds|) with drift = odom_heading_drift_degpm and
// σ_d = odom_distance_noise_m_per_sqrt_m, σ_θ = odom_heading_noise_deg_per_sqrt_m; the odometry pose integrates ds', dθ'.
// A reading is published at t = 0 and then every 1/odom_rate_hz of simulated time (at the
// end of the step that crosses the publication time; its timestamp is that step's time).
// Odometry.distance_m is the signed measured path length.
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
#include "visnav_sim/world.hpp"

namespace visnav::sim {

struct RobotParams {
  std::string name = "sim";  ///< registry name the camera refers to
  std::string world;         ///< world file or name (config/worlds/<name>.yaml); "" = none (camera brings its own)
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
  int seed = 1;
  double pose_history_s = 5.0;        ///< how far back pose_at() can look (camera latency)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<RobotParams>& schema();
};

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
  /// World the robot drives in (may be null).
  [[nodiscard]] const std::shared_ptr<const World>& world() const { return world_; }

 private:
  void substep_locked(double dt_s);
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
  std::deque<std::pair<double, Pose2D>> history_;
};

/// Start pose of a robot: params.start_pose (or the world's start, or the origin) with the
/// displacement applied in the start pose's frame.
[[nodiscard]] Pose2D resolve_start(const RobotParams& params, const World* world);

/// The `sim` robot plugin object. Registers its core in the process-wide registry under
/// params.name for its lifetime (a second live robot of the same name is an error).
class SimRobot final : public Robot, public SimulationControl {
 public:
  using Params = RobotParams;
  /// `params` is the `params:` block; relative `world` paths resolve against its file.
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

  [[nodiscard]] const std::shared_ptr<RobotCore>& core() const { return core_; }

 private:
  explicit SimRobot(std::shared_ptr<RobotCore> core);
  std::shared_ptr<RobotCore> core_;
};

}  // namespace visnav::sim
