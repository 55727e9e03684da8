#include "visnav/visual_memory/params.hpp"

#include "visnav/visual_memory/controllers.hpp"

namespace visnav::visual_memory {

const ParamSchema<CameraParams>& CameraParams::schema() {
  using P = CameraParams;
  static const auto s = ParamSchema<P>{}
                            .field("horizontal_fov_deg", &P::horizontal_fov_deg, "camera horizontal field of view, deg")
                            .range(10.0, 170.0)
                            .field("camera_forward_m", &P::camera_forward_m,
                                   "delta: camera ahead of the robot's rotation axis, m (seed 004)")
                            .range(-2.0, 2.0);
  return s;
}

namespace {
const std::vector<std::pair<std::string, std::string>> kCameraFields = {{"horizontal_fov_deg", "horizontal_fov_deg"},
                                                                        {"camera_forward_m", "camera_forward_m"}};
}  // namespace

Status TeachParams::validate() const {
  VISNAV_TRY(schema().check(*this));
  if (min_reference_spacing_m >= max_reference_spacing_m)
    return Error{"min_reference_spacing_m must be below max_reference_spacing_m", ErrorCode::inconsistent};
  if (klt_window_px % 2 == 0) return Error{"klt_window_px must be odd", ErrorCode::inconsistent};
  return ok();
}

const ParamSchema<TeachParams>& TeachParams::schema() {
  using P = TeachParams;
  static const auto s =
      ParamSchema<P>{}
          .include(&P::camera, CameraParams::schema(), kCameraFields)
          .field("max_features", &P::max_features, "Harris corners per reference").range(10, 5000)
          .field("harris_quality", &P::harris_quality, "corner quality, share of the best corner").range(1e-4, 0.5)
          .field("min_corner_distance_px", &P::min_corner_distance_px, "minimal distance between corners, px").range(1.0, 100.0)
          .field("harris_k", &P::harris_k, "Harris detector k").range(0.01, 0.25)
          .field("klt_window_px", &P::klt_window_px, "KLT window side, px (odd)").range(5, 61)
          .field("klt_levels", &P::klt_levels, "KLT pyramid levels").range(0, 6)
          .field("klt_max_fb_error_px", &P::klt_max_fb_error_px, "KLT forward-backward error limit, px").range(0.05, 10.0)
          .field("lost_fraction", &P::lost_fraction, "new reference when this share of its features is lost").range(0.05, 0.95)
          .field("max_reconstruction_error_px", &P::max_reconstruction_error_px,
                 "new reference when the reference-to-frame epipolar RMS exceeds this, px")
          .range(0.1, 50.0)
          .field("min_reference_spacing_m", &P::min_reference_spacing_m, "minimal odometric spacing of references, m")
          .range(0.0, 50.0)
          .field("max_reference_spacing_m", &P::max_reference_spacing_m, "maximal odometric spacing of references, m")
          .range(0.1, 100.0)
          .field("min_baseline_m", &P::min_baseline_m, "no triangulation below this baseline (pure rotation), m")
          .range(0.0, 10.0)
          .field("ransac_threshold_px", &P::ransac_threshold_px, "essential-matrix inlier threshold, px").range(0.1, 20.0)
          .field("estimator", &P::estimator, "robust estimator of E").one_of({"ransac", "lmeds", "magsac", "mlesac"})
          .field("max_triangulation_error_px", &P::max_triangulation_error_px, "triangulated point reprojection limit, px")
          .range(0.1, 50.0)
          .field("min_parallax_deg", &P::min_parallax_deg, "triangulated point minimal parallax, deg").range(0.0, 45.0)
          .field("png_compression", &P::png_compression, "PNG level of the stored reference images").range(0, 9);
  return s;
}

Status ReplayParams::validate() const {
  VISNAV_TRY(schema().check(*this));
  if (!controller_from_string(controller)) return Error{"unknown controller '" + controller + "'", ErrorCode::out_of_range};
  if (klt_window_px % 2 == 0) return Error{"klt_window_px must be odd", ErrorCode::inconsistent};
  if (turn_speed_mps > speed_mps) return Error{"turn_speed_mps must not exceed speed_mps", ErrorCode::inconsistent};
  if (min_pose_points > min_tracked)
    return Error{"min_pose_points must not exceed min_tracked", ErrorCode::inconsistent};
  return ok();
}

const ParamSchema<ReplayParams>& ReplayParams::schema() {
  using P = ReplayParams;
  static const auto s =
      ParamSchema<P>{}
          .include(&P::camera, CameraParams::schema(), kCameraFields)
          .field("controller", &P::controller, "control law (seed 003 centroid, seed 004 RH/IJP/IJPU/IJC/IJCU/AIJCA)")
          .one_of({"centroid", "RH", "IJP", "IJPU", "IJC", "IJCU", "AIJCA"})
          .field("centroid_statistic", &P::centroid_statistic, "centroid controller: mean or median").one_of({"mean", "median"})
          .field("centroid_gain_radps", &P::centroid_gain_radps, "centroid controller gain a, rad/s per normalised unit")
          .range(0.0, 20.0)
          .field("lambda", &P::lambda, "gain lambda of the seed 004 laws, 1/s").range(0.0, 20.0)
          .field("uniform_depth_m", &P::uniform_depth_m, "z-bar of IJPU/IJCU, m").range(0.1, 1000.0)
          .field("speed_mps", &P::speed_mps, "forward speed v-bar, m/s").range(0.01, 3.0)
          .field("turn_speed_mps", &P::turn_speed_mps, "forward speed in detected turns, m/s").range(0.01, 3.0)
          .field("turn_offset_norm", &P::turn_offset_norm, "centroid shift that marks a turn (normalised)").range(0.0, 2.0)
          .field("max_angular_radps", &P::max_angular_radps, "angular speed clamp, rad/s").range(0.01, 5.0)
          .field("lateral_gain_radps_per_m", &P::lateral_gain_radps_per_m,
                 "lateral term k_y: omega += k_y * (lateral offset from the PnP pose), rad/s per m; 0 = the papers' laws")
          .range(0.0, 10.0)
          .field("lateral_clamp_m", &P::lateral_clamp_m, "largest lateral offset the lateral term acts on, m")
          .range(0.01, 10.0)
          .field("klt_window_px", &P::klt_window_px, "KLT window side, px (odd)").range(5, 61)
          .field("klt_levels", &P::klt_levels, "KLT pyramid levels").range(0, 6)
          .field("klt_max_fb_error_px", &P::klt_max_fb_error_px, "KLT forward-backward error limit, px").range(0.05, 10.0)
          .field("reprojection_gate_px", &P::reprojection_gate_px, "reprojection gate of tracked/resumed points, px")
          .range(0.5, 100.0)
          .field("min_tracked", &P::min_tracked, "fewer tracked features: relocalise").range(5, 1000)
          .field("min_pose_points", &P::min_pose_points, "PnP inliers needed for a pose").range(4, 1000)
          .field("switch_rule", &P::switch_rule, "reference switching: pose (seed 003) or image_error (seed 004)")
          .one_of({"pose", "image_error"})
          .field("switch_error_px", &P::switch_error_px, "tau_epsilon: image error threshold, px").range(0.1, 100.0)
          .field("rise_px", &P::rise_px, "image error rise over its minimum that counts as rising, px").range(0.0, 50.0)
          .field("switch_margin_m", &P::switch_margin_m, "pose rule: switch this close before the reference plane, m")
          .range(0.0, 10.0)
          .field("switch_odometry_margin_m", &P::switch_odometry_margin_m,
                 "a reference this far behind the odometric distance is passed regardless, m")
          .range(0.1, 100.0)
          .field("max_lost_frames", &P::max_lost_frames, "frames without relocalisation before failing").range(1, 100000)
          .field("relocalise_window", &P::relocalise_window, "references searched either side when relocalising")
          .range(0, 1000)
          .field("relocalise_detector", &P::relocalise_detector, "wide-baseline relocalisation: orb, or sift (seed 003)")
          .one_of({"orb", "sift"})
          .field("orb_features", &P::orb_features, "features per image when relocalising (ORB or SIFT)").range(50, 10000)
          .field("orb_ratio", &P::orb_ratio, "ratio test of relocalisation matches").range(0.3, 1.0)
          .field("min_relocalise_inliers", &P::min_relocalise_inliers, "homography inliers to accept a relocalisation")
          .range(8, 10000)
          .field("illumination_compensation", &P::illumination_compensation,
                 "match the frame's brightness to the reference's before tracking from the reference")
          .field("goal_overshoot_m", &P::goal_overshoot_m, "past the edge length by this: finished by odometry, m")
          .range(0.0, 100.0);
  return s;
}

}  // namespace visnav::visual_memory
