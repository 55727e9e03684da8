// visnav IPT obstacles — the thesis's robocentric EKF (robocentric_ekf.hpp, Ch. 7) driven by the
// frame-pair pipeline (pipeline.hpp): wheel odometry predicts, the pair's GROUND features are the
// landmarks ([ours] glue; issue 16, docs/obstacles.md "The EKF on rendered frames").
//
// The pipeline re-detects its corners at every pair's first frame, so a landmark lives for one
// pair: for each pair, the filter first moves by the odometry from the last frame it saw to the
// pair's first frame and takes the first frame's ground points as new landmarks (exactly as
// measured, the thesis's initialisation), then moves by the odometry across the pair and
// updates with the second frame's ground points of the same tracks. What the wheels get wrong
// across a pair (a wheel-size asymmetry turns the robot's belief, spec §11 item 23) is corrected
// by where the ground points moved in the image.
//
// The tracks used are those whose discrepancy D was computed (below the guard band, within the
// classifier's range: labelled GROUND, in a band, OBSTACLE by D), at most `max_observations` per
// pair (spread over the pair's list), and only those that moved like the pair's other points
// (gate_sd). Not only the GROUND labels: D uses the odometry, so those labels select the tracks
// that agree with the odometry's error (issue 38; docs/obstacles.md). Must not be used where the
// odometry's heading noise per pair approaches the pipeline's max_pair_rotation_rad (0.05 rad):
// the pipeline then restarts the pairs the noise turned and those steps are dead reckoning
// (the thesis's level 5, σθ = 0.032 rad per 5 cm: the filter lost to dead reckoning). Odometry increments get the covariance diag((σ_t·d)², (σ_t·d)², (σ_θ·d)²) for a
// travel of d metres, plus a floor that keeps it positive definite at d = 0.
//
// Frames: the odom frame (x, y, heading; metres, radians). The pose is anchored where reset() or
// the first pair put it: pose() = anchor ⊕ (the EKF's world pose). Not thread-safe; pure (no clock).
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "visnav/ipt_obstacles/classifier.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/ipt_obstacles/robocentric_ekf.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct GroundOdometryParams {
  double pixel_sd_px = 0.25;            ///< σ of a tracked corner's position, px (both frames)
  double translation_sd_per_m = 0.05;   ///< σ of the odometry's x and y increment per metre travelled
  double heading_sd_rad_per_m = 0.05;   ///< σ of the odometry's heading increment per metre travelled
  int max_observations = 60;            ///< ground features used per pair (bounds the EKF's cost)
  /// [ours] A track whose residual (second sighting minus the odometry's prediction from the
  /// first) is farther than gate_sd·σ + gate_floor_m from the pair's median residual is not used.
  double gate_sd = 3.0;
  double gate_floor_m = 0.01;

  [[nodiscard]] Status validate() const;
  static const ParamSchema<GroundOdometryParams>& schema();
};

class GroundOdometry {
 public:
  /// Error (out_of_range) naming the key when the camera or a param is out of range.
  static Result<GroundOdometry> create(const IptCamera& camera, GroundOdometryParams params = {});

  /// Starts again at `odom_pose` (empty EKF, zero covariance).
  void reset(const Pose2D& odom_pose);

  /// One pair of the pipeline: the odometry poses of its first and second frame and its
  /// classified features (pixel_previous in the first frame, pixel in the second). Error
  /// (invalid_value) for a non-finite pose or when the EKF rejects the update (the state then
  /// follows the odometry for that pair).
  Status add_pair(const Pose2D& odom_first, const Pose2D& odom_second, std::span<const ClassifiedFeature> features);

  /// The corrected pose in the odom frame and its covariance (x, y, heading).
  [[nodiscard]] Pose2D pose() const;
  [[nodiscard]] Eigen::Matrix3d covariance() const { return ekf_.world_pose_covariance(); }
  /// Ground features the last pair's update used.
  [[nodiscard]] int last_observations() const { return last_observations_; }

 private:
  GroundOdometry(const IptCamera& camera, GroundOdometryParams params) : camera_(camera), params_(params) {}
  Status move_to(const Pose2D& odom_pose, std::span<const GroundObservation> observations);

  IptCamera camera_;
  GroundOdometryParams params_;
  RobocentricEkf ekf_{EkfParams{.max_missed_frames = 1}};
  Pose2D anchor_;
  Pose2D last_odom_;
  bool started_ = false;
  int next_id_ = 0;
  int last_observations_ = 0;
  std::vector<GroundObservation> first_, second_;
  std::vector<double> residual_x_, residual_y_;
};

}  // namespace visnav::ipt
