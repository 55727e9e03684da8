#include "visnav/visual_memory/geometry.hpp"

#include <cmath>
#include <algorithm>
#include <limits>
#include <numbers>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/video/tracking.hpp>

namespace visnav::visual_memory {

Intrinsics Intrinsics::from_fov(int width_px, int height_px, double horizontal_fov_deg) {
  Intrinsics k;
  k.focal_px = (width_px / 2.0) / std::tan(horizontal_fov_deg * std::numbers::pi / 360.0);
  k.cx_px = (width_px - 1) * 0.5;
  k.cy_px = (height_px - 1) * 0.5;
  return k;
}

int track_klt(const cv::Mat& from, const cv::Mat& to, const std::vector<cv::Point2f>& in, std::vector<cv::Point2f>& out,
              std::vector<std::uint8_t>& ok, const KltParams& params, bool use_initial) {
  ok.assign(in.size(), 0);
  if (in.empty() || from.empty() || to.empty() || from.size() != to.size()) {
    out.resize(in.size());
    return 0;
  }
  const cv::Size win(params.window_px, params.window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
  std::vector<std::uint8_t> st1, st2;
  std::vector<float> err;
  std::vector<cv::Point2f> back;
  try {
    if (!use_initial || out.size() != in.size()) out = in;
    cv::calcOpticalFlowPyrLK(from, to, in, out, st1, err, win, params.levels, term, cv::OPTFLOW_USE_INITIAL_FLOW);
    back = in;
    cv::calcOpticalFlowPyrLK(to, from, out, back, st2, err, win, params.levels, term, cv::OPTFLOW_USE_INITIAL_FLOW);
  } catch (const cv::Exception&) {
    out.resize(in.size());
    return 0;
  }
  int n = 0;
  const float w = static_cast<float>(to.cols - 1), h = static_cast<float>(to.rows - 1);
  for (std::size_t j = 0; j < in.size(); ++j) {
    const cv::Point2f& p = out[j];
    const bool inside = std::isfinite(p.x) && std::isfinite(p.y) && p.x >= 0 && p.y >= 0 && p.x <= w && p.y <= h;
    const double fb = cv::norm(back[j] - in[j]);
    if (st1[j] && st2[j] && inside && fb <= params.max_fb_error_px) {
      ok[j] = 1;
      ++n;
    }
  }
  return n;
}

const char* to_string(GeometryStatus s) {
  switch (s) {
    case GeometryStatus::ok: return "ok";
    case GeometryStatus::too_few_correspondences: return "too few correspondences";
    case GeometryStatus::no_baseline: return "no baseline (pure rotation)";
    case GeometryStatus::degenerate: return "degenerate geometry";
  }
  return "?";
}

namespace {

/// Squared Sampson distance (px²) of a correspondence to the epipolar geometry F (pixels).
double sampson_px2(const cv::Matx33d& F, const cv::Point2f& a, const cv::Point2f& b) {
  const cv::Vec3d x1(a.x, a.y, 1.0), x2(b.x, b.y, 1.0);
  const cv::Vec3d Fx1 = F * x1, Ftx2 = F.t() * x2;
  const double num = x2.dot(Fx1);
  const double den = Fx1[0] * Fx1[0] + Fx1[1] * Fx1[1] + Ftx2[0] * Ftx2[0] + Ftx2[1] * Ftx2[1];
  return den > 1e-18 ? num * num / den : std::numeric_limits<double>::infinity();
}

/// MLESAC (Torr & Zisserman 2000, as seed 003 uses it): minimal 5-point samples, each solution
/// scored by the negative log-likelihood of a mixture of Gaussian inlier residuals (σ = the
/// threshold) and uniform outliers over the image diagonal, the mixing share γ by EM; the best
/// E and its inliers (posterior inlier probability > 0.5). Deterministic (fixed seed).
cv::Mat mlesac_essential(const std::vector<cv::Point2f>& first, const std::vector<cv::Point2f>& second,
                         const cv::Matx33d& K, double sigma_px, cv::Mat& mask) {
  const int n = static_cast<int>(first.size());
  const double v = std::hypot(2.0 * K(0, 2), 2.0 * K(1, 2));  // uniform outlier range, px
  const double norm = 1.0 / (std::sqrt(2.0 * std::numbers::pi) * sigma_px);
  const cv::Matx33d Kinv = K.inv();
  std::mt19937 rng(0x5EED);
  std::uniform_int_distribution<int> pick(0, n - 1);
  double best_nll = std::numeric_limits<double>::infinity();
  cv::Matx33d best;
  bool found = false;
  std::vector<double> d2(static_cast<std::size_t>(n));
  for (int it = 0; it < 300; ++it) {
    int idx[5];
    for (int k = 0; k < 5; ++k) {
      bool again = true;
      while (again) {
        idx[k] = pick(rng);
        again = false;
        for (int q = 0; q < k; ++q) again = again || idx[q] == idx[k];
      }
    }
    std::vector<cv::Point2f> a(5), b(5);
    for (int k = 0; k < 5; ++k) {
      a[static_cast<std::size_t>(k)] = first[static_cast<std::size_t>(idx[k])];
      b[static_cast<std::size_t>(k)] = second[static_cast<std::size_t>(idx[k])];
    }
    cv::Mat Es;
    try {
      Es = cv::findEssentialMat(a, b, cv::Mat(K), cv::RANSAC, 0.999, sigma_px);
    } catch (const cv::Exception&) {
      continue;
    }
    if (Es.empty() || Es.cols != 3 || Es.rows % 3 != 0) continue;
    Es.convertTo(Es, CV_64F);
    for (int s = 0; s < Es.rows / 3; ++s) {
      cv::Matx33d E;
      for (int i = 0; i < 9; ++i) E.val[i] = Es.at<double>(3 * s + i / 3, i % 3);
      const cv::Matx33d F = Kinv.t() * E * Kinv;
      for (int j = 0; j < n; ++j) d2[static_cast<std::size_t>(j)] = sampson_px2(F, first[static_cast<std::size_t>(j)],
                                                                               second[static_cast<std::size_t>(j)]);
      double gamma = 0.5;
      for (int em = 0; em < 5; ++em) {
        double sum = 0.0;
        for (double e : d2) {
          const double pin = gamma * norm * std::exp(-0.5 * e / (sigma_px * sigma_px));
          sum += pin / (pin + (1.0 - gamma) / v);
        }
        gamma = std::clamp(sum / n, 1e-3, 1.0 - 1e-3);
      }
      double nll = 0.0;
      for (double e : d2) nll -= std::log(gamma * norm * std::exp(-0.5 * e / (sigma_px * sigma_px)) + (1.0 - gamma) / v);
      if (std::isfinite(nll) && nll < best_nll) {
        best_nll = nll;
        best = E;
        found = true;
      }
    }
  }
  if (!found) return {};
  // posterior inliers of the best model
  const cv::Matx33d F = Kinv.t() * best * Kinv;
  mask = cv::Mat(n, 1, CV_8U, cv::Scalar(0));
  for (int j = 0; j < n; ++j) {
    const double e = sampson_px2(F, first[static_cast<std::size_t>(j)], second[static_cast<std::size_t>(j)]);
    mask.at<std::uint8_t>(j) = e <= 9.0 * sigma_px * sigma_px ? 1 : 0;  // within 3σ
  }
  return cv::Mat(best, true);
}

int estimator_flag(const std::string& name) {
  if (name == "lmeds") return cv::LMEDS;
  if (name == "magsac") return cv::USAC_MAGSAC;
  return cv::RANSAC;
}

double epipolar_distance_px(const cv::Matx33d& F, const cv::Point2f& a, const cv::Point2f& b) {
  const cv::Vec3d x1(a.x, a.y, 1.0), x2(b.x, b.y, 1.0);
  const cv::Vec3d l2 = F * x1, l1 = F.t() * x2;
  const double num = std::abs(x2.dot(l2));
  const double d2 = num / std::max(1e-12, std::hypot(l2[0], l2[1]));
  const double d1 = num / std::max(1e-12, std::hypot(l1[0], l1[1]));
  return 0.5 * (d1 + d2);
}

}  // namespace

RelativeGeometry relative_geometry(const std::vector<cv::Point2f>& first, const std::vector<cv::Point2f>& second,
                                   const Intrinsics& intrinsics, double baseline_m, const GeometryParams& params) {
  RelativeGeometry g;
  const std::size_t n = first.size();
  g.has_3d.assign(n, 0);
  g.points_m.assign(n, cv::Point3f(0, 0, 0));
  if (n < 5 || second.size() != n) {
    g.status = GeometryStatus::too_few_correspondences;
    return g;
  }
  const cv::Matx33d K = intrinsics.K();
  cv::Mat mask;
  cv::Mat E;
  try {
    if (params.estimator == "mlesac") {
      E = mlesac_essential(first, second, K, params.ransac_threshold_px, mask);
    } else {
      E = cv::findEssentialMat(first, second, cv::Mat(K), estimator_flag(params.estimator), 0.999,
                               params.ransac_threshold_px, mask);
    }
  } catch (const cv::Exception&) {
    E.release();
  }
  if (E.empty() || E.rows != 3 || E.cols != 3) {
    g.status = GeometryStatus::degenerate;
    return g;
  }
  cv::Matx33d Ed;
  for (int i = 0; i < 9; ++i) Ed.val[i] = E.at<double>(i / 3, i % 3);
  if (!cv::checkRange(E)) {
    g.status = GeometryStatus::degenerate;
    return g;
  }
  // Error of the estimator's inliers against the fundamental matrix K^-T E K^-1.
  const cv::Matx33d F = K.inv().t() * Ed * K.inv();
  double sum2 = 0.0;
  int inliers = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (mask.empty() || !mask.at<std::uint8_t>(static_cast<int>(j))) continue;
    const double d = epipolar_distance_px(F, first[j], second[j]);
    sum2 += d * d;
    ++inliers;
  }
  g.inliers = inliers;
  g.rms_error_px = inliers > 0 ? std::sqrt(sum2 / inliers) : 0.0;
  if (!std::isfinite(g.rms_error_px)) {
    g.status = GeometryStatus::degenerate;
    return g;
  }
  // Pure rotation (or standing still): E carries no usable translation, nothing to triangulate.
  if (!(baseline_m >= params.min_baseline_m)) {
    g.status = GeometryStatus::no_baseline;
    return g;
  }
  cv::Mat Rm, tm, pose_mask = mask.clone();
  int good = 0;
  try {
    good = cv::recoverPose(E, first, second, cv::Mat(K), Rm, tm, pose_mask);
  } catch (const cv::Exception&) {
    good = 0;
  }
  if (good < 5 || Rm.empty() || tm.empty() || !cv::checkRange(Rm) || !cv::checkRange(tm)) {
    g.status = good < 5 ? GeometryStatus::too_few_correspondences : GeometryStatus::degenerate;
    return g;
  }
  Rm.convertTo(Rm, CV_64F);
  tm.convertTo(tm, CV_64F);
  for (int i = 0; i < 9; ++i) g.R.val[i] = Rm.at<double>(i / 3, i % 3);
  const cv::Vec3d t_unit(tm.at<double>(0), tm.at<double>(1), tm.at<double>(2));
  g.t_m = t_unit * baseline_m;
  // Triangulate in the first frame (P1 = K[I|0], P2 = K[R|t]), then move to the second's.
  cv::Matx34d P1 = cv::Matx34d::eye(), P2;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P2(r, c) = g.R(r, c);
    P2(r, 3) = g.t_m[r];
  }
  std::vector<cv::Point2f> a, b;
  std::vector<int> index;
  for (std::size_t j = 0; j < n; ++j)
    if (pose_mask.at<std::uint8_t>(static_cast<int>(j))) {
      a.push_back(first[j]);
      b.push_back(second[j]);
      index.push_back(static_cast<int>(j));
    }
  cv::Mat X;
  try {
    cv::triangulatePoints(cv::Mat(K * P1), cv::Mat(K * P2), a, b, X);
  } catch (const cv::Exception&) {
    g.status = GeometryStatus::degenerate;
    return g;
  }
  X.convertTo(X, CV_64F);
  const double min_parallax_rad = params.min_parallax_deg * std::numbers::pi / 180.0;
  const cv::Vec3d c2 = -(g.R.t() * g.t_m);  // second camera centre in the first frame
  int made = 0;
  for (std::size_t k = 0; k < index.size(); ++k) {
    const double w = X.at<double>(3, static_cast<int>(k));
    if (std::abs(w) < 1e-12) continue;
    const cv::Vec3d p1(X.at<double>(0, static_cast<int>(k)) / w, X.at<double>(1, static_cast<int>(k)) / w,
                       X.at<double>(2, static_cast<int>(k)) / w);
    const cv::Vec3d p2 = g.R * p1 + g.t_m;
    if (!(p1[2] > 0.05 && p2[2] > 0.05) || !cv::checkRange(cv::Mat(p2))) continue;
    const cv::Vec3d r1 = p1 / cv::norm(p1), r2 = (p1 - c2) / cv::norm(p1 - c2);
    if (std::acos(std::clamp(r1.dot(r2), -1.0, 1.0)) < min_parallax_rad) continue;
    const cv::Vec3d q1 = K * p1, q2 = K * p2;
    const double e1 = std::hypot(q1[0] / q1[2] - a[k].x, q1[1] / q1[2] - a[k].y);
    const double e2 = std::hypot(q2[0] / q2[2] - b[k].x, q2[1] / q2[2] - b[k].y);
    if (std::max(e1, e2) > params.max_triangulation_error_px) continue;
    g.has_3d[index[k]] = 1;
    g.points_m[index[k]] = cv::Point3f(static_cast<float>(p2[0]), static_cast<float>(p2[1]), static_cast<float>(p2[2]));
    ++made;
  }
  g.status = made >= 5 ? GeometryStatus::ok : GeometryStatus::degenerate;
  return g;
}

double PoseEstimate::heading_change_rad() const { return std::atan2(R(0, 2), R(2, 2)); }

PoseEstimate estimate_pose(const std::vector<cv::Point3f>& points_ref_m, const std::vector<cv::Point2f>& pixels,
                           const Intrinsics& intrinsics, int min_points, double reprojection_px) {
  PoseEstimate pose;
  if (static_cast<int>(points_ref_m.size()) < std::max(min_points, 4) || pixels.size() != points_ref_m.size()) return pose;
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  bool solved = false;
  try {
    solved = cv::solvePnPRansac(points_ref_m, pixels, cv::Mat(intrinsics.K()), cv::noArray(), rvec, tvec, false, 100,
                                static_cast<float>(reprojection_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
    if (solved && static_cast<int>(inliers.size()) >= min_points) {
      std::vector<cv::Point3f> in3;
      std::vector<cv::Point2f> in2;
      for (int i : inliers) {
        in3.push_back(points_ref_m[static_cast<std::size_t>(i)]);
        in2.push_back(pixels[static_cast<std::size_t>(i)]);
      }
      solved = cv::solvePnP(in3, in2, cv::Mat(intrinsics.K()), cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
    }
  } catch (const cv::Exception&) {
    solved = false;
  }
  if (!solved || static_cast<int>(inliers.size()) < min_points || !cv::checkRange(rvec) || !cv::checkRange(tvec)) return pose;
  cv::Mat Rm;
  cv::Rodrigues(rvec, Rm);
  Rm.convertTo(Rm, CV_64F);
  tvec.convertTo(tvec, CV_64F);
  for (int i = 0; i < 9; ++i) pose.R.val[i] = Rm.at<double>(i / 3, i % 3);
  pose.t_m = cv::Vec3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  pose.inliers = static_cast<int>(inliers.size());
  pose.ok = cv::checkRange(Rm) && std::isfinite(pose.t_m[0]) && std::isfinite(pose.t_m[1]) && std::isfinite(pose.t_m[2]);
  return pose;
}

bool project(const PoseEstimate& pose, const cv::Point3f& point_ref_m, const Intrinsics& intrinsics, cv::Point2f& pixel,
             double* depth_m) {
  const cv::Vec3d p = pose.R * cv::Vec3d(point_ref_m.x, point_ref_m.y, point_ref_m.z) + pose.t_m;
  if (!(p[2] > 0.05) || !std::isfinite(p[0]) || !std::isfinite(p[1])) return false;
  pixel = cv::Point2f(static_cast<float>(intrinsics.focal_px * p[0] / p[2] + intrinsics.cx_px),
                      static_cast<float>(intrinsics.focal_px * p[1] / p[2] + intrinsics.cy_px));
  if (depth_m != nullptr) *depth_m = p[2];
  return true;
}

}  // namespace visnav::visual_memory
