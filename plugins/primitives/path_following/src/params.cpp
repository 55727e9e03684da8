#include "visnav/path_following/params.hpp"

namespace visnav::path_following {

Status PathFollowerParams::validate() const {
  if (horizon_search_min_ratio >= horizon_search_max_ratio)
    return fail("horizon_search_min_ratio (" + std::to_string(horizon_search_min_ratio) +
                ") must be below horizon_search_max_ratio (" + std::to_string(horizon_search_max_ratio) + ")");
  if (median_blur_px % 2 == 0) return fail("median_blur_px must be odd (got " + std::to_string(median_blur_px) + ")");
  if (min_area_share >= fill_area_share)
    return fail("min_area_share (" + std::to_string(min_area_share) + ") must be below fill_area_share (" +
                std::to_string(fill_area_share) + ")");
  if (model_blend >= 1.0) return fail("model_blend must be below 1 (1 would never learn)");
  if (taught_gate_distance > 0.0 && taught_gate_distance < class_distance)
    return fail("taught_gate_distance (" + std::to_string(taught_gate_distance) +
                ") must be 0 (off) or at least class_distance (" + std::to_string(class_distance) +
                "): a tighter gate would reject models the classification calls path");
  return ok();
}

const ParamSchema<PathFollowerParams>& PathFollowerParams::schema() {
  using P = PathFollowerParams;
  static const auto s =
      ParamSchema<P>{}
          .field("horizon_mode", &P::horizon_mode, "horizon: auto (strongest row-colour change), row, ratio")
          .one_of({"auto", "row", "ratio"})
          .field("horizon_row_px", &P::horizon_row_px, "horizon row in mode 'row'").range(0, 100000)
          .field("horizon_ratio", &P::horizon_ratio, "horizon as share of the height (mode 'ratio', auto fallback)")
          .range(0.0, 0.95)
          .field("horizon_search_min_ratio", &P::horizon_search_min_ratio, "auto: top of the search band (share of height)")
          .range(0.0, 1.0)
          .field("horizon_search_max_ratio", &P::horizon_search_max_ratio, "auto: bottom of the search band (share of height)")
          .range(0.0, 1.0)
          .field("horizon_window_px", &P::horizon_window_px, "auto: rows averaged above and below a candidate").range(1, 64)
          .field("horizon_min_contrast", &P::horizon_min_contrast, "auto: minimal band-mean colour change (BGR levels)")
          .range(0.0, 442.0)
          .field("horizon_margin_px", &P::horizon_margin_px, "rows skipped below the horizon").range(0, 1000)
          .field("median_blur_px", &P::median_blur_px, "median blur kernel (odd, 1 = off)").range(1, 15)
          .field("seg_sigma", &P::seg_sigma, "graph segmentation Gaussian sigma").range(0.0, 5.0)
          .field("seg_k", &P::seg_k, "graph segmentation threshold k (larger = bigger segments)").range(1.0, 100000.0)
          .field("seg_min_size_px", &P::seg_min_size_px, "graph segmentation minimal segment size (input pixels)")
          .range(1, 1000000)
          .field("seg_scale", &P::seg_scale, "resize factor of the image the graph segmentation runs on").range(0.2, 1.0)
          .field("ref_bottom_width_ratio", &P::ref_bottom_width_ratio, "reference trapezoid bottom width (share of width)")
          .range(0.05, 1.0)
          .field("ref_top_width_ratio", &P::ref_top_width_ratio, "reference trapezoid top width (share of width)")
          .range(0.05, 1.0)
          .field("ref_height_ratio", &P::ref_height_ratio, "reference trapezoid height (share of the ground height)")
          .range(0.02, 1.0)
          .field("ref_merge_distance", &P::ref_merge_distance, "Mahalanobis distance below which reference segments merge")
          .range(0.0, 100.0)
          .field("ref_min_coverage", &P::ref_min_coverage, "share of the reference region a kept model must cover")
          .range(0.0, 1.0)
          .field("class_distance", &P::class_distance, "Mahalanobis distance below which a segment is path")
          .range(0.0, 100.0)
          .field("colour_noise_floor", &P::colour_noise_floor, "std added to every colour axis (feature levels)")
          .range(0.1, 100.0)
          .field("model_blend", &P::model_blend, "weight of the previous frame's reference models").range(0.0, 0.99)
          .field("taught_gate_distance", &P::taught_gate_distance,
                 "reject re-learned path models farther than this from the taught appearance (sigma, 0 = off)")
          .range(0.0, 100.0)
          .field("opening_kernel_px", &P::opening_kernel_px, "morphological opening kernel (0 = off)").range(0, 51)
          .field("dark_mean_intensity", &P::dark_mean_intensity, "mean grey level below which the frame is dark")
          .range(0.0, 255.0)
          .field("min_area_share", &P::min_area_share, "path region below this share of the ground = path lost")
          .range(0.0, 1.0)
          .field("fill_area_share", &P::fill_area_share, "path region above this share of the ground = fills image")
          .range(0.0, 1.0)
          .field("multi_model_max_share", &P::multi_model_max_share,
                 "with several reference models, a larger region drops the least covering model")
          .range(0.0, 1.0)
          .field("alpha_radps", &P::alpha_radps, "angular speed per unit mean normalised offset (rad/s)").range(0.0, 10.0)
          .field("beta_mps", &P::beta_mps, "forward speed when the path spans every ground row (m/s)").range(0.0, 5.0)
          .field("turn_slowdown_mps_per_radps", &P::turn_slowdown_mps_per_radps, "forward speed lost per rad/s of turn")
          .range(0.0, 10.0)
          .field("max_linear_mps", &P::max_linear_mps, "forward speed clamp (m/s)").range(0.0, 5.0)
          .field("max_angular_radps", &P::max_angular_radps, "angular speed clamp (rad/s)").range(0.0, 10.0)
          .field("grace_s", &P::grace_s, "seconds a bad path status is tolerated before 'path lost'").range(0.0, 60.0);
  return s;
}

}  // namespace visnav::path_following
