// visnav visual memory — tracking and local geometry (seed 003 Sec. II-A/B), pure functions.
//
// Frames and units: pixels (origin top-left, u right, v down); camera frames are OpenCV's
// (x right, y down, z forward), metres. A pose (R, t) maps a point of frame A into frame B:
// X_B = R X_A + t. Nothing here allocates hidden state, reads a clock or throws: OpenCV errors
// are caught and reported as a status.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace visnav::visual_memory {

/// Pinhole with square pixels and the principal point at the image centre.
struct Intrinsics {
  double focal_px = 0.0;
  double cx_px = 0.0;
  double cy_px = 0.0;
  static Intrinsics from_fov(int width_px, int height_px, double horizontal_fov_deg);
  [[nodiscard]] cv::Matx33d K() const { return {focal_px, 0, cx_px, 0, focal_px, cy_px, 0, 0, 1}; }
  /// Normalised image coordinates (X, Y) of seed 004: (u - cx)/f, (v - cy)/f.
  [[nodiscard]] cv::Point2d normalise(const cv::Point2f& p) const {
    return {(p.x - cx_px) / focal_px, (p.y - cy_px) / focal_px};
  }
};

struct KltParams {
  int window_px = 21;
  int levels = 3;
  double max_fb_error_px = 1.0;
};

/// Pyramidal Lucas-Kanade from `from` to `to` with a forward-backward check: `ok[j]` is set when
/// the point was tracked both ways, the round trip ends within max_fb_error_px of the start and
/// the result lies inside the image. With `use_initial`, `out` holds the initial guesses.
/// Images CV_8UC1 of equal size. Returns the number of ok points.
int track_klt(const cv::Mat& from, const cv::Mat& to, const std::vector<cv::Point2f>& in, std::vector<cv::Point2f>& out,
              std::vector<std::uint8_t>& ok, const KltParams& params, bool use_initial = false);

/// Outcome of the reference→current geometry (one line per reason).
enum class GeometryStatus {
  ok,
  too_few_correspondences,  ///< fewer than 5 (the 5-point algorithm's minimum) or too few inliers
  no_baseline,              ///< odometric baseline below the minimum: pure rotation, no 3D
  degenerate,               ///< E not found, or no point in front of both cameras / too little parallax
};
[[nodiscard]] const char* to_string(GeometryStatus s);

struct GeometryParams {
  double min_baseline_m = 0.1;
  double ransac_threshold_px = 1.0;
  std::string estimator = "ransac";   ///< ransac, lmeds, magsac (OpenCV), mlesac (ours, seed 003's estimator)
  double max_triangulation_error_px = 2.0;
  double min_parallax_deg = 0.5;
};

/// Relative pose between two views and the triangulated points, in the second view's frame.
struct RelativeGeometry {
  GeometryStatus status = GeometryStatus::degenerate;
  cv::Matx33d R = cv::Matx33d::eye();   ///< first → second
  cv::Vec3d t_m{0.0, 0.0, 0.0};         ///< metric: unit translation × baseline_m
  std::vector<std::uint8_t> has_3d;     ///< per correspondence
  std::vector<cv::Point3f> points_m;    ///< per correspondence, second view's frame
  int inliers = 0;
  double rms_error_px = 0.0;            ///< essential-matrix inliers' symmetric epipolar RMS
};

/// 5-point essential matrix (robust estimator per params) + cheirality + triangulation; the
/// translation's scale is `baseline_m` (odometry between the views). Correspondences in pixels.
[[nodiscard]] RelativeGeometry relative_geometry(const std::vector<cv::Point2f>& first, const std::vector<cv::Point2f>& second,
                                                 const Intrinsics& intrinsics, double baseline_m, const GeometryParams& params);

/// Current camera pose from 3D points of a reference (reference frame) and their pixels now.
struct PoseEstimate {
  bool ok = false;
  cv::Matx33d R = cv::Matx33d::eye();   ///< reference → current
  cv::Vec3d t_m{0.0, 0.0, 0.0};
  int inliers = 0;
  /// The current camera's position in the reference frame, -Rᵀt (z > 0: past the reference).
  [[nodiscard]] cv::Vec3d position_in_reference_m() const { return -(R.t() * t_m); }
  /// θ - θ_ref, rad, counter-clockwise (seed 004 Sec. V-A, from R about the camera's y axis).
  [[nodiscard]] double heading_change_rad() const;
};

/// PnP with RANSAC; `ok` only for a finite pose with at least min_points inliers.
[[nodiscard]] PoseEstimate estimate_pose(const std::vector<cv::Point3f>& points_ref_m, const std::vector<cv::Point2f>& pixels,
                                         const Intrinsics& intrinsics, int min_points, double reprojection_px);

/// Pixel of `point_ref_m` seen from a camera at pose (R, t) relative to the reference; false
/// when behind the camera (z ≤ 5 cm) or non-finite.
bool project(const PoseEstimate& pose, const cv::Point3f& point_ref_m, const Intrinsics& intrinsics, cv::Point2f& pixel,
             double* depth_m = nullptr);

}  // namespace visnav::visual_memory
