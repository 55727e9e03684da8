#include "visnav/ipt_obstacles/ground_odometry.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::ipt {

namespace {

Eigen::Vector3d vec(const Pose2D& p) { return {p.x_m, p.y_m, p.heading_rad}; }

}  // namespace

Status GroundOdometryParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<GroundOdometryParams>& GroundOdometryParams::schema() {
  using P = GroundOdometryParams;
  static const auto s =
      ParamSchema<P>{}
          .field("pixel_sd_px", &P::pixel_sd_px, "sigma of a tracked corner, px").range(0.01, 20.0)
          .field("translation_sd_per_m", &P::translation_sd_per_m, "odometry x/y sigma per metre").range(1e-4, 1.0)
          .field("heading_sd_rad_per_m", &P::heading_sd_rad_per_m, "odometry heading sigma per metre").range(1e-5, 1.0)
          .field("max_observations", &P::max_observations, "ground features per pair").range(2, 1000)
          .field("gate_sd", &P::gate_sd, "residual gate in sigmas about the median residual").range(0.5, 100.0)
          .field("gate_floor_m", &P::gate_floor_m, "residual gate floor").range(0.0, 1.0);
  return s;
}

Result<GroundOdometry> GroundOdometry::create(const IptCamera& camera, GroundOdometryParams params) {
  VISNAV_TRY(camera.validate());
  VISNAV_TRY(params.validate());
  return GroundOdometry(camera, params);
}

void GroundOdometry::reset(const Pose2D& odom_pose) {
  ekf_ = RobocentricEkf(EkfParams{.max_missed_frames = 1});
  anchor_ = odom_pose;
  last_odom_ = odom_pose;
  started_ = true;
  last_observations_ = 0;
}

Status GroundOdometry::move_to(const Pose2D& odom_pose, std::span<const GroundObservation> observations) {
  // The increment in the last frame's robot frame: ⊖last ⊕ now.
  const Eigen::Vector3d u = oplus(ominus(vec(last_odom_)), vec(odom_pose));
  const double d = std::hypot(u(0), u(1));
  const double st = params_.translation_sd_per_m * d, sh = params_.heading_sd_rad_per_m * d;
  constexpr double kFloor = 1e-12;  // keeps Q positive definite when the robot did not move
  const Eigen::Vector3d q(st * st + kFloor, st * st + kFloor, sh * sh + kFloor);
  last_odom_ = odom_pose;
  return ekf_.step(u, q.asDiagonal(), observations);
}

Status GroundOdometry::add_pair(const Pose2D& odom_first, const Pose2D& odom_second,
                                std::span<const ClassifiedFeature> features) {
  if (!std::isfinite(odom_first.x_m) || !std::isfinite(odom_first.y_m) || !std::isfinite(odom_first.heading_rad) ||
      !std::isfinite(odom_second.x_m) || !std::isfinite(odom_second.y_m) || !std::isfinite(odom_second.heading_rad))
    return Error{"GroundOdometry: non-finite odometry pose", ErrorCode::invalid_value};
  if (!started_) reset(odom_first);
  first_.clear();
  second_.clear();
  int ground = 0;
  // Every track whose D was computed (below the guard band, within range), not only the GROUND
  // labels: D ≤ β is computed with the odometry's increment, so at odometry noise per pair of the
  // order of β (2.1 cm) the label keeps just the tracks that agree with the wrong odometry and the
  // filter lost to dead reckoning (issue 38). The median gate below, which does not depend on the
  // odometry's error, picks the ground.
  auto usable = [](const ClassifiedFeature& f) {
    return f.reason == ClassReason::d_ground || f.reason == ClassReason::d_band || f.reason == ClassReason::d_obstacle ||
           f.reason == ClassReason::d_below_ground;
  };
  for (const auto& f : features) ground += usable(f) ? 1 : 0;
  // Spread the cap over the list (the tracker's corners are ordered by strength, not place).
  const int stride = std::max(1, (ground + params_.max_observations - 1) / params_.max_observations);
  int index = 0;
  for (const auto& f : features) {
    if (!usable(f)) continue;
    if (index++ % stride != 0) continue;
    auto a = ground_observation(camera_, f.pixel_previous, params_.pixel_sd_px, next_id_);
    auto b = ground_observation(camera_, f.pixel, params_.pixel_sd_px, next_id_);
    ++next_id_;
    if (!a || !b) continue;  // one end above the ground plane's reach: not a landmark
    first_.push_back(*a);
    second_.push_back(*b);
  }
  // Gate: a point that is not on the ground (the low part of a van labelled GROUND, a track that
  // slid) moves unlike the others. Predict each second sighting from the first by the odometry,
  // and drop the tracks whose residual is far from the median residual (what the odometry got
  // wrong is common to all ground points; a non-ground point's error is its own).
  if (first_.size() >= 3) {
    const Eigen::Vector3d u = oplus(ominus(vec(odom_first)), vec(odom_second));
    const double c = std::cos(u(2)), s = std::sin(u(2));
    residual_x_.clear();
    residual_y_.clear();
    for (std::size_t i = 0; i < first_.size(); ++i) {
      const Eigen::Vector2d d = first_[i].z_m - u.head<2>();
      residual_x_.push_back(second_[i].z_m(0) - (c * d(0) + s * d(1)));
      residual_y_.push_back(second_[i].z_m(1) - (-s * d(0) + c * d(1)));
    }
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    const double mx = median(residual_x_), my = median(residual_y_);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < first_.size(); ++i) {
      const double sd = std::sqrt((first_[i].covariance + second_[i].covariance).trace());
      if (std::hypot(residual_x_[i] - mx, residual_y_[i] - my) > params_.gate_sd * sd + params_.gate_floor_m) continue;
      first_[kept] = first_[i];
      second_[kept] = second_[i];
      ++kept;
    }
    first_.resize(kept);
    second_.resize(kept);
  }
  last_observations_ = static_cast<int>(second_.size());
  // Before the pair: old landmarks are dropped (one pair's life), the first frame's are added.
  Status st = move_to(odom_first, first_);
  Status across = move_to(odom_second, second_);
  if (!st) return st;
  return across;
}

Pose2D GroundOdometry::pose() const {
  const Pose2D w = ekf_.world_pose();
  const Eigen::Vector3d p = oplus(vec(anchor_), vec(w));
  return {p(0), p(1), p(2)};
}

}  // namespace visnav::ipt
