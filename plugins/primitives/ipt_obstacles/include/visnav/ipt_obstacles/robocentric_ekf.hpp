// visnav IPT obstacles — the robocentric EKF of the thesis (Ch. 7; spec §8): odometry
// increments predict, GROUND features back-projected by the IPT are the landmarks.
//
// State (7.8), everything in the current robot frame R_k (x forward, y left, metres, rad):
//   x = [ x_W^{R_k} (3: pose of the world frame seen from the robot) ; L_1 (2) ; … ; L_N (2) ]
// The world frame is the first robot frame: x_W starts at zero mean and zero covariance.
// One step (spec §8.6 order): predict (7.9: append the odometry increment u ~ N(û, Q), the
// robot's motion from k−1 to k in R_{k−1}) → update (7.10-7.16: h_j = ⊖u ⊕ L_j for every
// observed landmark, stacked) → compose (7.17-7.20: move the state into R_k with ⊖u, drop u)
// → add new landmarks exactly as measured (covariance R, no cross-covariance) → remove
// landmarks unobserved for max_missed_frames frames (thesis: 3).
// Data association is by the tracker's feature id ("known correspondences").
// The world pose is ⊖x_W with covariance J⊖ P_WW J⊖ᵀ. Not thread-safe; pure (no clock).
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct EkfParams {
  int max_missed_frames = 3;  ///< a landmark unobserved this many frames in a row is removed (thesis 3)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<EkfParams>& schema();
};

/// One GROUND observation: the IPT ground point in the robot frame and its covariance.
struct GroundObservation {
  int id = -1;                    ///< tracker id (association)
  Eigen::Vector2d z_m;            ///< x forward, y left, metres
  Eigen::Matrix2d covariance;     ///< R_i, m²
};

/// The IPT ground point of `pixel` in the robot frame and its covariance from σ_px of pixel
/// noise on u and v propagated through the IPT (spec §8.4 [I]: R = J diag(σ², σ²) Jᵀ, by
/// central differences). Error (out_of_range) when the pixel does not meet the ground.
[[nodiscard]] Result<GroundObservation> ground_observation(const IptCamera& camera, const cv::Point2d& pixel,
                                                           double sigma_px, int id);

class RobocentricEkf {
 public:
  explicit RobocentricEkf(EkfParams params = {});

  /// One frame: odometry increment û (dx forward, dy left, dθ in R_{k−1}) with covariance Q,
  /// and this frame's ground observations. Error (invalid_value) for a non-finite input or a
  /// non-positive-definite innovation covariance (the state is then left as predicted and composed).
  Status step(const Eigen::Vector3d& u, const Eigen::Matrix3d& Q, std::span<const GroundObservation> observations);

  /// Robot pose in the world frame (the first robot frame) and its covariance (x, y, θ).
  [[nodiscard]] Pose2D world_pose() const;
  [[nodiscard]] Eigen::Matrix3d world_pose_covariance() const;
  [[nodiscard]] int landmark_count() const { return static_cast<int>(ids_.size()); }
  [[nodiscard]] const std::vector<int>& landmark_ids() const { return ids_; }
  /// Landmark `index` in the robot frame.
  [[nodiscard]] Eigen::Vector2d landmark(int index) const { return x_.segment<2>(3 + 2 * index); }
  [[nodiscard]] const Eigen::VectorXd& state() const { return x_; }
  [[nodiscard]] const Eigen::MatrixXd& covariance() const { return P_; }

 private:
  EkfParams params_;
  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  std::vector<int> ids_;
  std::vector<int> missed_;
};

/// Compounding operators of Castellanos et al. (spec §8.1) on (x, y, θ).
[[nodiscard]] Eigen::Vector3d oplus(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
[[nodiscard]] Eigen::Vector3d ominus(const Eigen::Vector3d& a);

}  // namespace visnav::ipt
