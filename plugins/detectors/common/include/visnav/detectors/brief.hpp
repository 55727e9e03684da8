// visnav detectors — BRIEF binary descriptor (Calonder, Lepetit, Strecha, Fua, ECCV 2010).
//
// 256 intensity comparisons τ(p; a, b) = [I_s(a) < I_s(b)] between point pairs inside a
// patch of side S = `patch_size_px` (48 by default) centred on the keypoint, packed into 32
// bytes (bit i of the descriptor is bit (i % 8) of byte i / 8, least significant first).
// I_s is the image smoothed with a `kernel_size_px`² box filter read from the integral image
// (a 7×7 box has the standard deviation of the paper's σ = 2 Gaussian). The point pairs follow
// the paper's sampling G II: a and b i.i.d. isotropic Gaussian with σ = S/5, truncated to the
// disc of radius S/2 − 1, rounded to whole pixels, drawn once from a fixed seed with a
// portable generator — every build and platform gets the same pattern.
//
// Upright (default): the pattern is used as is (the papers' choice for planar teach-and-repeat).
// Oriented: the keypoint angle is the intensity-centroid direction atan2(m01, m10) over the disc
// of radius S/2 − 1 (written to KeyPoint::angle in degrees, [0, 360), image axes, y down), and
// the pattern rotated to the nearest of 30 steps (12°) is used.
//
// Keypoints whose patch (plus half the smoothing box) does not fit inside the image are removed.
// Thread-safety: one instance per thread (it owns buffers); the pattern itself is immutable.
// Hot path: compute() reuses its integral image and offset tables while the image width stays.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/result.hpp"

namespace visnav::detectors {

struct BriefParams {
  int patch_size_px = 48;   ///< S, even or odd, [16, 96]
  int kernel_size_px = 7;   ///< odd box side used for smoothing, [1, 15]
  bool upright = true;      ///< false: steer the pattern by the intensity-centroid angle

  [[nodiscard]] Status validate() const;
};

/// One BRIEF test: compare smoothed intensities at (x1, y1) and (x2, y2) relative to the keypoint.
struct BriefTest {
  int x1, y1, x2, y2;
};

class BriefExtractor {
 public:
  static constexpr int kBits = 256;
  static constexpr int kBytes = 32;
  static constexpr int kOrientationBins = 30;

  /// `params` must satisfy validate() (asserted; use set_params() for a Status).
  explicit BriefExtractor(const BriefParams& params = {});
  Status set_params(const BriefParams& params);
  [[nodiscard]] const BriefParams& params() const { return params_; }

  /// Keypoints nearer than this to any image edge (after rounding) are removed by compute().
  [[nodiscard]] int border_px() const;

  /// Describes `keypoints` in `grey` (CV_8UC1). Keypoints that do not fit are erased (order of
  /// the rest kept); when !upright, KeyPoint::angle is set. `descriptors` becomes N×32 CV_8U
  /// (its buffer is reused when large enough). `integral` may pass a (h+1)×(w+1) CV_32S integral
  /// image of `grey` (e.g. StarDetector::integral()) to skip computing one.
  void compute(const cv::Mat& grey, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
               const cv::Mat& integral = cv::Mat());

  /// The sampling pattern (upright) for patch size S; the same for every call and process.
  [[nodiscard]] static std::vector<BriefTest> make_pattern(int patch_size_px);

  /// Replaces the comparison pairs (GRIEF: pairs trained for appearance change). `pattern` must
  /// pass validate_pattern() for the current patch_size_px; a later set_params() that changes
  /// the patch size restores the BRIEF pattern. An empty `pattern` restores it too.
  Status set_pattern(std::vector<BriefTest> pattern);
  [[nodiscard]] const std::vector<BriefTest>& pattern() const { return pattern_; }
  /// Checks a pattern: exactly kBits tests, every point inside the disc of radius S/2 − 1 (so
  /// border_px() holds), no test comparing a point with itself. The message names the test index.
  [[nodiscard]] static Status validate_pattern(const std::vector<BriefTest>& pattern, int patch_size_px);

 private:
  void rebuild_offsets(int integral_stride);
  [[nodiscard]] float centroid_angle_deg(const cv::Mat& grey, int x, int y) const;

  BriefParams params_;
  std::vector<BriefTest> pattern_;
  int offsets_stride_ = -1;
  std::vector<std::int32_t> offsets_;  ///< per orientation bin: 256 tests × 8 integral offsets
  std::vector<int> disc_half_width_;   ///< centroid disc: half width per row offset
  cv::Mat own_integral_;
};

/// Hamming distance between two descriptors of `bytes` bytes.
[[nodiscard]] int hamming_distance(const std::uint8_t* a, const std::uint8_t* b, int bytes);

}  // namespace visnav::detectors
