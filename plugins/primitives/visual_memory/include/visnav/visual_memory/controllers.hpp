// visnav visual memory — the control laws on ω (v is fixed), pure functions.
//
//  * centroid (seed 003 Sec. II-C): ω = -a (x_c - x_n), x the mean or median of the features'
//    normalised abscissae in the current image (c) and in the next reference (n). Seed 003 feeds
//    this into a car's steering angle Φ; for a unicycle it is the yaw rate.
//  * seed 004 Sec. V, with X, Y normalised image coordinates of the current image, z the depth
//    of each point in the current camera frame, δ the camera's offset ahead of the rotation axis:
//      RH    ω = -λ Δθ, Δθ = θ - θ_i from the rotation between the current and reference views;
//      IJP   s = (X_1, Y_1, …, X_n, Y_n), L_P,v = (X/z, Y/z), L_P,ω = (δ/z + 1 + X², XY),
//            ω = -L_S,ω⁺ (λ e + L_S,v v̄), e = s - s*  (law (3));
//      IJPU  IJP with z_j = z̄;
//      IJC   s = (X_G, Y_G) the centroid, L_S,v = mean(X/z, Y/z), L_S,ω = mean(δ/z + 1 + X², XY), law (3);
//      IJCU  IJC with z_j = z̄;
//      AIJCA s = X_G, L_S,v = 0, L_S,ω = 1: ω = -λ (X_G - X_iG).
//    L_S,ω⁺ = (L_S,ωᵀ L_S,ω)⁻¹ L_S,ωᵀ; for a column vector this is L_S,ωᵀ / |L_S,ω|².
// Every law returns a finite ω or no value with a reason (never NaN).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/types.hpp>

namespace visnav::visual_memory {

enum class Controller { centroid, RH, IJP, IJPU, IJC, IJCU, AIJCA };
[[nodiscard]] std::optional<Controller> controller_from_string(std::string_view name);
[[nodiscard]] const char* to_string(Controller c);
/// True for the laws that need each point's depth (IJP, IJC) or the relative rotation (RH).
[[nodiscard]] bool needs_pose(Controller c);

struct ControlInput {
  std::vector<cv::Point2d> current_norm;    ///< matched points in the current image, normalised
  std::vector<cv::Point2d> reference_norm;  ///< the same points in the reference image
  std::vector<double> depth_m;              ///< current-frame depth per point (IJP, IJC); may be empty otherwise
  std::optional<double> heading_change_rad; ///< θ - θ_i (RH)
  double speed_mps = 0.0;                   ///< v̄
  double camera_forward_m = 0.0;            ///< δ
};

struct ControlGains {
  double centroid_gain_radps = 1.0;
  bool centroid_median = true;
  double lambda = 1.0;
  double uniform_depth_m = 5.0;
};

struct ControlOutput {
  std::optional<double> angular_radps;  ///< empty: the law could not be evaluated
  std::string reason;                   ///< why not (one line), empty when evaluated
};

[[nodiscard]] ControlOutput compute_control(Controller c, const ControlInput& in, const ControlGains& gains);

/// ε_i of seed 004 Sec. V: mean pixel distance between matched points (pixels in, pixels out).
[[nodiscard]] double image_error_px(const std::vector<cv::Point2f>& current, const std::vector<cv::Point2f>& reference);

}  // namespace visnav::visual_memory
