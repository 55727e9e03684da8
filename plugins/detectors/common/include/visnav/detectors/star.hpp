// visnav detectors — CenSurE/STAR keypoint detector (Agrawal, Konolige, Blas, ECCV 2008).
//
// The STAR filter is a bi-level centre-surround filter whose shape is the union of an upright
// square and the same square rotated by 45° (an eight-pointed star). At each scale the response
// is
//     response = mean(inner star of radius n) − mean(ring between inner star n and outer star 2n)
// in grey levels (weights over the overlap of the two squares count twice; the filter has zero
// DC response, so a uniform image gives 0 everywhere). The upright square sum comes from the
// ordinary integral image, the rotated square (a lattice diamond |dx|+|dy| ≤ r) from two
// slanted integral images that cumulate row prefix sums along the two 45° diagonals; every
// filter value costs 10 table reads independent of the scale (the two reads on the centre row
// go to the per-row difference of the slanted tables).
//
// Scales: inner radii 1, 2, 3, 4, 6, 8, 11, 16, 23, 32 px (outer = 2 × inner) as long as the outer
// diameter 4·inner+1 does not exceed `max_size_px` (45 → 7 scales, largest outer diameter 45).
// Per pixel the scale with the largest |response| wins; keypoints are local extrema of that
// signed plane over a `suppress_nonmax_size_px` square window (i.e. over window × all scales)
// with |response| > `response_threshold`. Line-like extrema are rejected with the Harris-type
// ratio trace²/det of the second-moment matrix of (a) the response plane ("projected",
// `line_threshold_projected`) and (b) the binarised "this pixel chose the same scale" image
// (`line_threshold_binarized`), both sampled on a 9×9 grid spanning the outer filter.
//
// Output keypoints: pt = pixel centre (integer coordinates), size = outer filter diameter
// (4·inner + 1 px), response = |filter response| (grey levels), octave = scale index
// (0 = smallest), angle = -1 (not estimated), class_id = +1 bright blob / -1 dark blob.
//
// Thread-safety: a StarDetector owns its work buffers; use one instance per thread.
// Hot path: detect() reuses all buffers while the image size stays the same. The optimised
// implementation (vectorised per-row kernels, NMS from running max/min rows) returns exactly
// the keypoints of the direct definition above, in raster order.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/result.hpp"

namespace visnav::detectors {

struct StarParams {
  int max_size_px = 45;                   ///< largest outer filter diameter, [5, 129]
  double response_threshold = 30.0;       ///< min |mean(inner) − mean(ring)|, grey levels, > 0
  double line_threshold_projected = 10.0; ///< reject if trace²/det of response gradients ≥ this
  double line_threshold_binarized = 8.0;  ///< same on the binarised scale image
  int suppress_nonmax_size_px = 5;        ///< side of the non-maximum suppression window (odd, ≥ 3)
  int border_px = 0;                      ///< keypoints closer than this to the image edge are dropped

  [[nodiscard]] Status validate() const;
};

class StarDetector {
 public:
  /// `params` must satisfy validate() (checked with an assert; use set_params() for a Status).
  explicit StarDetector(const StarParams& params = {});

  Status set_params(const StarParams& params);
  [[nodiscard]] const StarParams& params() const { return params_; }
  /// Changes only the response threshold (grey levels, > 0); used by the adaptive threshold.
  void set_response_threshold(double threshold) { params_.response_threshold = threshold; }

  /// Number of filter scales for the current max_size_px.
  [[nodiscard]] int scale_count() const { return static_cast<int>(scales_.size()); }
  /// Outer filter diameter of scale `index`, px.
  [[nodiscard]] int scale_size_px(int index) const;

  /// Detects STAR keypoints in `grey` (CV_8UC1, any size; images smaller than the smallest
  /// filter give no keypoints). Clears `keypoints` first. Not sorted.
  void detect(const cv::Mat& grey, std::vector<cv::KeyPoint>& keypoints);

  /// Upright integral image of the last detect() input: (h+1)×(w+1) CV_32S, same layout as
  /// cv::integral(grey, sum, CV_32S). Valid until the next detect(); BRIEF can reuse it.
  [[nodiscard]] const cv::Mat& integral() const { return integral_; }

 private:
  struct Radius {
    int box_half_px;      ///< upright square half width n
    int diamond_radius_px;///< rotated square: |dx|+|dy| ≤ round(n·√2)
    int margin_px;        ///< min distance from the image edge for the filter to fit
    double area;          ///< weight sum (overlap counted twice)
  };
  struct Scale {
    int inner;            ///< index into radii_
    int outer;
    float inner_weight;   ///< 1 / inner area
    float ring_weight;    ///< 1 / (outer area − inner area)
    int outer_half_px;    ///< n_out
    int margin_px;        ///< margin of the outer filter
  };

  void build_scales();
  void build_tables(const cv::Mat& grey);
  void compute_responses(int width, int height);
  void find_extrema(int width, int height, std::vector<cv::KeyPoint>& keypoints);
  [[nodiscard]] bool is_line(int x, int y, int scale, int width, int height) const;

  StarParams params_;
  std::vector<Radius> radii_;
  std::vector<Scale> scales_;

  cv::Mat integral_;                 ///< upright integral, CV_32S (h+1)×(w+1)
  std::vector<std::int32_t> diag_a_; ///< row prefixes cumulated along (+1,−1), same layout
  std::vector<std::int32_t> diag_b_; ///< row prefixes cumulated along (−1,−1), same layout
  std::vector<std::int32_t> row_prefix_;
  std::vector<std::int32_t> diag_diff_;  ///< diag_a_ − diag_b_ of the current row (w+1)
  std::vector<std::vector<std::int32_t>> star_rows_;  ///< per radius: star sums of one row
  std::vector<float> response_;      ///< winning signed response per pixel, h×w
  std::vector<std::uint8_t> scale_;  ///< winning scale index per pixel, h×w
  std::vector<char> needed_;         ///< per radius: needed for the current row
  std::vector<float> row_max_;       ///< NMS: ring of (window) horizontal running maxima rows
  std::vector<float> row_min_;       ///< NMS: same for minima
  std::vector<std::uint8_t> candidate_;  ///< NMS: 1 where the pixel is a thresholded window extremum
};

}  // namespace visnav::detectors
