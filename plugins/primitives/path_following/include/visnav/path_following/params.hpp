// visnav path following — parameters of the segmentation-based path follower (seed 000 Sec. 4).
//
// Units: image quantities in pixels (`_px`) or as shares of an image dimension (`_ratio`,
// `_share`, in [0, 1]); colour quantities in the 8-bit HSV-cone feature space described in
// path_follower.hpp (each axis spans roughly [-255, 255]); Mahalanobis distances in standard
// deviations; speeds in m/s and rad/s.
//
// Parse with `PathFollowerParams::schema().parse(node)`; every field is range-checked and
// `validate()` enforces the cross-field rules. Thread-safety: plain value type.
#pragma once

#include <string>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::path_following {

struct PathFollowerParams {
  // --- Horizon (Fig. 2 a-b): only the image below the horizon is processed. ---
  /// "auto": row of the strongest change of mean row colour inside the search band (falls back
  /// to `horizon_ratio` when the change is weaker than `horizon_min_contrast`);
  /// "row": `horizon_row_px`; "ratio": `horizon_ratio` × image height.
  std::string horizon_mode = "auto";
  int horizon_row_px = 0;
  double horizon_ratio = 0.35;
  double horizon_search_min_ratio = 0.05;  ///< auto search band, share of the height from the top
  double horizon_search_max_ratio = 0.75;
  int horizon_window_px = 4;               ///< rows averaged above and below a candidate row
  double horizon_min_contrast = 12.0;      ///< minimal L2 distance of the band means (BGR levels)
  int horizon_margin_px = 2;               ///< rows skipped below the detected horizon

  // --- Segmentation (Sec. 4.1). ---
  int median_blur_px = 5;       ///< median kernel size (odd; 1 = off)
  double seg_sigma = 0.5;       ///< Felzenszwalb-Huttenlocher Gaussian pre-smoothing
  double seg_k = 100.0;         ///< FH threshold constant k (larger = larger segments)
  int seg_min_size_px = 60;     ///< FH minimal segment size, in input-image pixels
  /// The graph segmentation runs on the ground image resized by this factor (labels are scaled
  /// back with nearest-neighbour); 1 = full resolution. Statistics and masks stay at full size.
  double seg_scale = 0.5;

  // --- Reference region and classification (Sec. 4.2). ---
  /// Trapezoid at the bottom of the ground image, centred horizontally; widths are shares of
  /// the image width, the height a share of the ground (below-horizon) height.
  double ref_bottom_width_ratio = 0.4;
  double ref_top_width_ratio = 0.3;
  double ref_height_ratio = 0.25;
  double ref_merge_distance = 2.0;   ///< merge two segment models closer than this (symmetric Mahalanobis)
  double ref_min_coverage = 0.2;     ///< keep a merged model covering at least this share of the region
  double class_distance = 3.0;       ///< a segment is path when its mean is this close to a reference model
  double colour_noise_floor = 4.0;   ///< std added in quadrature on every colour axis (regularises Σ)
  double model_blend = 0.0;          ///< weight of the previous frame's reference models, [0, 1)
  /// Taught-appearance gate (PathFollower::set_taught_models): a re-learned reference model whose
  /// mean is farther than this (classification distance in the taught model's spread, σ) from
  /// every taught model is rejected; 0 = off. Without taught models the gate is inactive.
  double taught_gate_distance = 6.0;

  // --- Mask post-processing and status. ---
  int opening_kernel_px = 5;         ///< elliptic opening kernel size (0 = off)
  double dark_mean_intensity = 25.0; ///< mean grey level of the ground image below this = dark frame
  double min_area_share = 0.03;      ///< region smaller than this share of the ground image = path lost
  double fill_area_share = 0.97;     ///< region larger than this share = path fills the image
  /// With several reference models, a region larger than this share means the reference region
  /// straddled the path edge: the least covering model is dropped (see path_follower.hpp).
  double multi_model_max_share = 0.85;

  // --- Control law (1), normalised; see path_follower.hpp. ---
  double alpha_radps = 0.8;                 ///< ω per unit mean normalised offset
  double beta_mps = 0.4;                    ///< v when the path spans every ground row and ω = 0
  double turn_slowdown_mps_per_radps = 0.5; ///< v -= this × |ω|
  double max_linear_mps = 0.5;
  double max_angular_radps = 1.0;

  // --- Grace period (PathLossMonitor; used by the behaviour-tree node). ---
  double grace_s = 1.0;

  [[nodiscard]] Status validate() const;
  static const ParamSchema<PathFollowerParams>& schema();
};

}  // namespace visnav::path_following
