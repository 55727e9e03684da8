// visnav IPT obstacles — inverse perspective transformation (IPT) of a pinhole camera over a
// flat ground (Bonin-Font thesis §4.2; restated in shared/spec/thesis-ipt-navigation.md §1).
//
// Frames and units:
//  * ground frame: the world frame of visnav/types.hpp (x, y on the ground plane z = 0, z up,
//    metres). Azimuths are radians counter-clockwise from +x.
//  * the camera's ground pose (LensPose) is the lens centre's (x, y) and the azimuth of the
//    optical axis' horizontal projection. The thesis measures its yaw θ from +y, so
//    θ = azimuth − π/2 (spec §1.1); the closed forms below are written with θ.
//  * pitch φ follows the thesis: negative looks down (the thesis rig: −9°). No roll.
//  * pixels (u, v): origin top-left, u right, v down; an undistorted image is assumed.
//    Metric image coordinates divided by f: x_n = (u − cx)/fx, y_n = (cy − v)/fy (y up).
//
// Everything is a pure function of its arguments; no allocation, thread-safe.
#pragma once

#include <optional>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

/// The camera the IPT needs: pinhole intrinsics (undistorted pixels), the lens height above
/// the ground and the pitch, plus where the lens sits on the robot (for lens_pose()).
struct IptCamera {
  int width_px = 320;
  int height_px = 240;
  double fx_px = 277.128;       ///< focal length in pixels along u
  double fy_px = 277.128;       ///< focal length in pixels along v
  double cx_px = 159.5;         ///< principal point
  double cy_px = 119.5;
  double height_m = 0.5;        ///< Z0: lens centre above the ground
  double pitch_rad = -0.0872665;  ///< φ; negative = optical axis below the horizon
  double forward_m = 0.0;       ///< lens ahead of the robot origin
  double lateral_m = 0.0;       ///< lens to the left of the robot origin

  /// Ranges from the schema, and that some ground is visible: the bottom image row must lie
  /// below the horizon row (else ErrorCode::out_of_range, "no ground visible ...").
  [[nodiscard]] Status validate() const;
  static const ParamSchema<IptCamera>& schema();
};

/// Lens position on the ground and optical-axis azimuth (CCW from +x), ground frame.
struct LensPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double azimuth_rad = 0.0;
};

/// The lens pose for a robot pose (world or odom frame, the result is in the same frame).
[[nodiscard]] LensPose lens_pose(const IptCamera& camera, const Pose2D& robot);

/// Direct perspective transformation (spec §1.2, the corrected (4.5)): pixel of a 3-D point
/// (ground frame, z up). nullopt when the point is not in front of the lens (Δ·o ≤ 1e-9 m).
/// The pixel may lie outside the image.
[[nodiscard]] std::optional<cv::Point2d> project_point(const IptCamera& camera, const LensPose& lens,
                                                       const cv::Vec3d& point_m);

/// Ground-plane back-projection of one pixel (spec §1.3-1.4, eqs. 4.7, 4.8, 4.13).
struct GroundHit {
  double lambda = 0.0;        ///< λ* of (4.13): > 0 the ray meets the ground ahead
  cv::Point2d ground_m;       ///< (x*, y*) on z = 0, valid only when lambda > 0
  [[nodiscard]] bool valid() const { return lambda > 0.0; }
};
[[nodiscard]] GroundHit back_project(const IptCamera& camera, const LensPose& lens, const cv::Point2d& pixel);

/// Horizon row v_h = cy + fy·tan φ (4.15): rows v < v_h look above the horizontal plane
/// through the lens (λ* < 0), so a feature there cannot be on the ground.
[[nodiscard]] double horizon_row_px(const IptCamera& camera);

/// Range and signed bearing of a ground point from the robot centre (spec §1.6 with the
/// real heading and atan2; bearing CCW positive, 0 = straight ahead).
struct RangeBearing {
  double range_m = 0.0;
  double bearing_rad = 0.0;
};
[[nodiscard]] RangeBearing range_bearing(const Pose2D& robot, const cv::Point2d& ground_m);

/// A ground point in the robot frame (x forward, y left) from its ground-frame position.
[[nodiscard]] cv::Point2d to_robot_frame(const Pose2D& robot, const cv::Point2d& ground_m);

}  // namespace visnav::ipt
