#include "visnav/ipt_obstacles/robocentric_ekf.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace visnav::ipt {

namespace {

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

Eigen::Matrix2d rotation(double theta) {
  Eigen::Matrix2d r;
  r << std::cos(theta), -std::sin(theta), std::sin(theta), std::cos(theta);
  return r;
}

/// ∂(⊖u ⊕ p)/∂u for a point p (2×3): [ −Rᵀ | (−s Δx + c Δy, −c Δx − s Δy)ᵀ ], Δ = p − t_u.
Eigen::Matrix<double, 2, 3> d_point_d_u(const Eigen::Vector3d& u, const Eigen::Vector2d& p) {
  const double c = std::cos(u(2)), s = std::sin(u(2));
  const Eigen::Vector2d d = p - u.head<2>();
  Eigen::Matrix<double, 2, 3> j;
  j.leftCols<2>() = -rotation(u(2)).transpose();
  j(0, 2) = -s * d(0) + c * d(1);
  j(1, 2) = -c * d(0) - s * d(1);
  return j;
}

}  // namespace

Eigen::Vector3d oplus(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = std::cos(a(2)), s = std::sin(a(2));
  return {a(0) + c * b(0) - s * b(1), a(1) + s * b(0) + c * b(1), wrap(a(2) + b(2))};
}

Eigen::Vector3d ominus(const Eigen::Vector3d& a) {
  const double c = std::cos(a(2)), s = std::sin(a(2));
  return {-c * a(0) - s * a(1), s * a(0) - c * a(1), wrap(-a(2))};
}

Status EkfParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<EkfParams>& EkfParams::schema() {
  static const auto s = ParamSchema<EkfParams>{}.field("max_missed_frames", &EkfParams::max_missed_frames,
                                                       "frames a landmark may go unobserved (thesis 3)")
                            .range(1, 1000);
  return s;
}

Result<GroundObservation> ground_observation(const IptCamera& camera, const cv::Point2d& pixel, double sigma_px,
                                             int id) {
  const Pose2D origin{0.0, 0.0, 0.0};
  const LensPose lens = lens_pose(camera, origin);
  auto at = [&](double du, double dv) { return back_project(camera, lens, {pixel.x + du, pixel.y + dv}); };
  const GroundHit c = at(0, 0), up = at(0, -0.5), down = at(0, 0.5), left = at(-0.5, 0), right = at(0.5, 0);
  if (!c.valid() || !up.valid() || !down.valid() || !left.valid() || !right.valid())
    return Error{"pixel (" + std::to_string(pixel.x) + ", " + std::to_string(pixel.y) + ") does not meet the ground",
                 ErrorCode::out_of_range};
  Eigen::Matrix2d j;  // ∂(x, y)/∂(u, v), robot frame
  j << right.ground_m.x - left.ground_m.x, down.ground_m.x - up.ground_m.x, right.ground_m.y - left.ground_m.y,
      down.ground_m.y - up.ground_m.y;
  GroundObservation o;
  o.id = id;
  o.z_m = {c.ground_m.x, c.ground_m.y};
  o.covariance = sigma_px * sigma_px * j * j.transpose();
  return o;
}

RobocentricEkf::RobocentricEkf(EkfParams params) : params_(params), x_(Eigen::VectorXd::Zero(3)), P_(Eigen::MatrixXd::Zero(3, 3)) {}

Status RobocentricEkf::step(const Eigen::Vector3d& u_in, const Eigen::Matrix3d& Q,
                            std::span<const GroundObservation> observations) {
  if (!u_in.allFinite() || !Q.allFinite()) return Error{"EKF: non-finite odometry", ErrorCode::invalid_value};
  const int n = static_cast<int>(x_.size());
  // Predict (7.9): append u.
  Eigen::VectorXd x(n + 3);
  x << x_, u_in;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(n + 3, n + 3);
  P.topLeftCorner(n, n) = P_;
  P.bottomRightCorner<3, 3>() = Q;
  const int iu = n;

  // Update (7.10-7.16) with the observations of known landmarks.
  std::vector<int> seen(ids_.size(), 0);
  std::vector<const GroundObservation*> known;
  std::vector<int> index;
  for (const auto& o : observations) {
    if (!o.z_m.allFinite() || !o.covariance.allFinite()) return Error{"EKF: non-finite observation", ErrorCode::invalid_value};
    for (std::size_t j = 0; j < ids_.size(); ++j)
      if (ids_[j] == o.id) {
        known.push_back(&o);
        index.push_back(static_cast<int>(j));
        seen[j] = 1;
        break;
      }
  }
  Status status = ok();
  if (!known.empty()) {
    const int m = static_cast<int>(known.size());
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2 * m, n + 3);
    Eigen::VectorXd innovation(2 * m);
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(2 * m, 2 * m);
    const Eigen::Vector3d u = x.segment<3>(iu);
    const Eigen::Matrix2d rt = rotation(u(2)).transpose();
    for (int k = 0; k < m; ++k) {
      const int il = 3 + 2 * index[static_cast<std::size_t>(k)];
      const Eigen::Vector2d L = x.segment<2>(il);
      innovation.segment<2>(2 * k) = known[static_cast<std::size_t>(k)]->z_m - rt * (L - u.head<2>());
      H.block<2, 2>(2 * k, il) = rt;
      H.block<2, 3>(2 * k, iu) = d_point_d_u(u, L);
      R.block<2, 2>(2 * k, 2 * k) = known[static_cast<std::size_t>(k)]->covariance;
    }
    const Eigen::MatrixXd S = H * P * H.transpose() + R;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      status = Error{"EKF: innovation covariance not positive definite; update skipped", ErrorCode::invalid_value};
    } else {
      const Eigen::MatrixXd K = ldlt.solve(H * P).transpose();  // P Hᵀ S⁻¹ (S, P symmetric)
      x += K * innovation;
      const Eigen::MatrixXd IKH = Eigen::MatrixXd::Identity(n + 3, n + 3) - K * H;
      P = IKH * P * IKH.transpose() + K * R * K.transpose();  // Joseph form of (I − KH)P
    }
  }

  // Compose (7.17-7.20): move everything into R_k and drop u.
  const Eigen::Vector3d u = x.segment<3>(iu);
  const Eigen::Matrix2d rt = rotation(u(2)).transpose();
  Eigen::VectorXd xn(n);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n, n + 3);
  // world pose: ⊖u ⊕ x_W
  const Eigen::Vector3d w = x.head<3>();
  xn.head<2>() = rt * (w.head<2>() - u.head<2>());
  xn(2) = wrap(w(2) - u(2));
  J.block<2, 2>(0, 0) = rt;
  J(2, 2) = 1.0;
  J.block<2, 3>(0, iu) = d_point_d_u(u, w.head<2>());
  J(2, iu + 2) = -1.0;
  for (int i = 3; i < n; i += 2) {
    const Eigen::Vector2d L = x.segment<2>(i);
    xn.segment<2>(i) = rt * (L - u.head<2>());
    J.block<2, 2>(i, i) = rt;
    J.block<2, 3>(i, iu) = d_point_d_u(u, L);
  }
  x_ = xn;
  P_ = J * P * J.transpose();

  // Add new landmarks exactly as measured.
  for (const auto& o : observations) {
    bool have = false;
    for (int id : ids_) have |= id == o.id;
    if (have) continue;
    const int k = static_cast<int>(x_.size());
    x_.conservativeResize(k + 2);
    x_.segment<2>(k) = o.z_m;
    Eigen::MatrixXd Pn = Eigen::MatrixXd::Zero(k + 2, k + 2);
    Pn.topLeftCorner(k, k) = P_;
    Pn.bottomRightCorner<2, 2>() = o.covariance;
    P_ = std::move(Pn);
    ids_.push_back(o.id);
    missed_.push_back(0);
    seen.push_back(1);
  }
  // Remove landmarks unobserved for max_missed_frames frames.
  std::vector<int> keep;  // state indices kept
  for (int i = 0; i < 3; ++i) keep.push_back(i);
  std::vector<int> ids, missed;
  for (std::size_t j = 0; j < ids_.size(); ++j) {
    const int miss = seen[j] != 0 ? 0 : missed_[j] + 1;
    if (miss >= params_.max_missed_frames) continue;
    ids.push_back(ids_[j]);
    missed.push_back(miss);
    keep.push_back(3 + 2 * static_cast<int>(j));
    keep.push_back(4 + 2 * static_cast<int>(j));
  }
  if (keep.size() != static_cast<std::size_t>(x_.size())) {
    Eigen::VectorXd xk(keep.size());
    Eigen::MatrixXd Pk(keep.size(), keep.size());
    for (std::size_t a = 0; a < keep.size(); ++a) {
      xk(static_cast<Eigen::Index>(a)) = x_(keep[a]);
      for (std::size_t b = 0; b < keep.size(); ++b)
        Pk(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) = P_(keep[a], keep[b]);
    }
    x_ = std::move(xk);
    P_ = std::move(Pk);
  }
  ids_ = std::move(ids);
  missed_ = std::move(missed);
  return status;
}

Pose2D RobocentricEkf::world_pose() const {
  const Eigen::Vector3d r = ominus(x_.head<3>());
  return {r(0), r(1), r(2)};
}

Eigen::Matrix3d RobocentricEkf::world_pose_covariance() const {
  const Eigen::Vector3d a = x_.head<3>();
  const double c = std::cos(a(2)), s = std::sin(a(2));
  Eigen::Matrix3d j;
  j << -c, -s, a(0) * s - a(1) * c, s, -c, a(0) * c + a(1) * s, 0, 0, -1;
  return j * P_.topLeftCorner<3, 3>() * j.transpose();
}

}  // namespace visnav::ipt
