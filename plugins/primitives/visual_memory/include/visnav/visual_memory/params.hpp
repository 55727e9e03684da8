// visnav visual memory — parameters of the visual-memory primitive (seeds 003 and 004,
// docs/visual_memory.md lists every value with its source).
//
// Units: image quantities in pixels (`_px`) or in normalised image coordinates (`_norm`: pixel
// offset divided by the focal length, the X, Y of seed 004 Sec. V); distances in metres, speeds
// in m/s and rad/s, gains as named. The camera is a pinhole with square pixels and the
// principal point at the image centre, focal length from `horizontal_fov_deg` (the simulator's
// and the feature primitive's model); `camera_forward_m` is seed 004's δ.
//
// Parse with `X::schema().parse(node)`; every field is range-checked and `validate()` adds the
// cross-field rules. Thread-safety: plain value types.
#pragma once

#include <string>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::visual_memory {

/// Camera model shared by teach and replay.
struct CameraParams {
  double horizontal_fov_deg = 60.0;  ///< horizontal field of view; fx = fy = (w/2)/tan(hfov/2)
  double camera_forward_m = 0.0;     ///< δ: camera ahead of the robot's rotation axis, m

  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<CameraParams>& schema();
};

/// Teaching (seed 003 Sec. II-A): Harris + KLT tracking, a new reference when the tracked set
/// has lost `lost_fraction` of the reference's features (or the 3D reconstruction error of the
/// reference→current geometry exceeds `max_reconstruction_error_px`).
struct TeachParams {
  CameraParams camera;
  int max_features = 300;                 ///< Harris corners kept per reference
  double harris_quality = 0.01;           ///< goodFeaturesToTrack qualityLevel (share of the best corner)
  double min_corner_distance_px = 8.0;    ///< goodFeaturesToTrack minDistance
  double harris_k = 0.04;                 ///< Harris detector free parameter
  int klt_window_px = 21;                 ///< KLT window side
  int klt_levels = 3;                     ///< KLT pyramid levels above the base
  double klt_max_fb_error_px = 1.0;       ///< forward-backward check: larger round-trip error drops the track
  double lost_fraction = 0.5;             ///< new reference when this share of the reference's features is lost
  double max_reconstruction_error_px = 2.0;  ///< new reference when the essential-matrix inlier RMS exceeds this
  double min_reference_spacing_m = 0.2;   ///< no reference closer than this (odometric) to the previous one
  double max_reference_spacing_m = 3.0;   ///< a reference at the latest after this distance
  double min_baseline_m = 0.1;            ///< below: no triangulation (pure rotation), the reference stores no 3D
  double ransac_threshold_px = 1.0;       ///< essential matrix inlier threshold
  std::string estimator = "ransac";       ///< robust estimator of E: ransac, lmeds, magsac, mlesac (seed 003's)
  double max_triangulation_error_px = 2.0;  ///< triangulated points reprojecting worse are dropped
  double min_parallax_deg = 0.5;          ///< triangulated points seen under less parallax are dropped
  int png_compression = 3;                ///< reference image PNG level (0-9)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<TeachParams>& schema();
};

/// Replay (seed 003 Sec. II-B/C; controllers of seed 004 Sec. V).
struct ReplayParams {
  CameraParams camera;
  /// Control law: centroid (seed 003's Φ = -a (x_c - x_n), unicycle form), RH, IJP, IJPU, IJC,
  /// IJCU, AIJCA (seed 004 Sec. V A-F).
  std::string controller = "centroid";
  std::string centroid_statistic = "median";  ///< centroid controller: mean or median of horizontal offsets
  double centroid_gain_radps = 1.0;   ///< a of seed 003 (rad/s per unit normalised offset)
  double lambda = 1.0;                ///< λ of seed 004's laws (1/s)
  double uniform_depth_m = 5.0;       ///< z̄ of IJPU/IJCU
  double speed_mps = 0.3;             ///< v̄ (straight)
  double turn_speed_mps = 0.15;       ///< v during detected turns (seed 003 Sec. II-C)
  double turn_offset_norm = 0.15;     ///< a turn: centroid shift current→next or next→next-next above this
  double max_angular_radps = 0.8;     ///< ω clamp (the step reports `saturated`)
  /// Not in the seeds: ω += k_y · x, x the camera's lateral offset (m, right positive) from the
  /// taught chord between the previous reference and I_i, from the PnP pose, so a lateral offset
  /// is steered out instead of decaying only with the features' mean inverse depth (measured:
  /// 0.27 → 0.05 m left after 14 m from 0.5 m, docs/visual_memory.md). 0 gives the papers' laws
  /// exactly. Only on frames with a pose; |x| is taken at most `lateral_clamp_m`.
  double lateral_gain_radps_per_m = 0.3;
  double lateral_clamp_m = 1.0;       ///< largest lateral offset the lateral term acts on, m
  int klt_window_px = 21;
  int klt_levels = 3;
  double klt_max_fb_error_px = 1.0;
  double reprojection_gate_px = 8.0;  ///< tracked points farther than this from their reprojection are dropped
  int min_tracked = 8;                ///< fewer tracked reference features: relocalise
  int min_pose_points = 6;            ///< PnP needs this many tracked points with 3D
  std::string switch_rule = "pose";   ///< pose (seed 003, image-error fallback) or image_error (seed 004)
  double switch_error_px = 4.0;       ///< τ_ε of seed 004 (image_error rule and goal stop)
  double rise_px = 0.5;               ///< ε "starts to rise": ε exceeds its minimum by this
  double switch_margin_m = 0.0;       ///< pose rule: switch once the camera is this close to the reference plane
  double switch_odometry_margin_m = 1.0;  ///< a reference this far behind the odometric distance is passed regardless
  int max_lost_frames = 30;           ///< consecutive frames without relocalising before the step fails
  int relocalise_window = 2;          ///< references searched either side of the current one
  /// Wide-baseline relocalisation: "orb" (binary, fast) or "sift" (seed 003's choice [8]).
  std::string relocalise_detector = "orb";
  int orb_features = 500;             ///< relocalisation features per image (ORB or SIFT)
  double orb_ratio = 0.8;             ///< Lowe ratio test
  int min_relocalise_inliers = 15;    ///< homography inliers to accept a relocalisation
  /// Map the frame's brightness (mean, standard deviation) onto the reference image's before
  /// tracking from the reference (resuming, relocalising): a global version of the affine
  /// contrast/brightness model of seed 003's tracker [6].
  bool illumination_compensation = true;
  double goal_overshoot_m = 1.0;      ///< past the edge length by this without the goal image: finished by odometry

  [[nodiscard]] Status validate() const;
  static const ParamSchema<ReplayParams>& schema();
};

}  // namespace visnav::visual_memory
