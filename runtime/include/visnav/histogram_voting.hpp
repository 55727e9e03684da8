// visnav SDK — descriptor matching and histogram-voting heading estimation: the feature
// primitive's estimator (namespace visnav::feature_replay, where it was written), in the SDK so that
// other plugins verify views with it without including a plugin's headers (relocalisation checks
// its place candidates with it, issue 21). Implemented in the runtime library
// (runtime/src/vision/histogram_voting.cpp).
//
// The bearing-only principle of seeds 000 (Sec. 3.3) and 002 (Sec. 2.4): features of the current
// image are matched with reference features (a local map, or landmarks at their expected
// positions); the horizontal displacements of the matched pairs are voted into a histogram; the
// most frequent displacement is the horizontal offset of the scene, which the replayers turn into
// a steering correction.
//
// Conventions:
//  * Image coordinates are pixels, u to the right, v down (visnav/types.hpp).
//  * offset_px = u(current) - u(reference) of the winning displacement: the horizontal position of
//    the scene in the current image minus its position in the reference (positive: content moved
//    right, i.e. the camera is rotated counter-clockwise (to the left) of the reference heading).
//  * heading_correction_rad = -atan(offset_px / focal_px): the counter-clockwise rotation that
//    brings the camera back to the reference heading (negative: turn right).
//
// Matching: each current feature (query) looks for its best and second best reference feature
// (brute force, Hamming for CV_8U descriptors, L2 for CV_32F) among the reference features that
// pass the vertical gate |v(current) - v(reference)| <= max_vertical_px (all if the gate is 0;
// the reference is sorted by v so the gate also prunes the search). A pair is kept when
//  best < ratio * second_best (Lowe's ratio test on distances; a single candidate passes),
//  best <= max_descriptor_distance (if > 0), and the pair is mutual best (if cross_check; "best"
//  of a reference feature is taken over the current features whose gate admits it).
//
// Histogram: bin_count bins of bin_width_px centred on zero (bin_count odd; with the defaults of
// stroll_bearnav, 41 bins of 20 px, the range is +-410 px). Displacements outside the range are
// dropped. Peak refinement: the centre of mass of the winning bin and its two neighbours seeds an
// iterated mean over the displacements within +-refine_window_px; those are the inliers.
// Confidence: 0 below min_inliers, else min(1, inliers / full_confidence_inliers) times the peak's
// distinctiveness 1 - runner_up / peak (runner_up: the largest bin at least two bins away from the
// peak; runner_up / peak is reported as `ambiguity`). The estimate is `valid` when
// confidence >= min_confidence.
//
// Thread-safety: a HeadingEstimator is not thread-safe (it owns per-frame buffers); use one per
// thread. Allocation: after the first few frames (buffers grown to the largest feature counts
// seen) estimate() does not allocate, except to build an Error for inconsistent input.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/devices.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::feature_replay {

/// Matching and histogram-voting parameters (config keys as named here).
struct HeadingParams {
  double ratio = 0.8;                    ///< Lowe ratio test on descriptor distances (1 = off); 0.8 chosen on
                                         ///< appearance-change pairs (docs/feature_replay.md, issue 13)
  bool cross_check = false;              ///< keep only mutual best matches
  double max_descriptor_distance = 0.0;  ///< absolute gate (Hamming bits or L2); 0 = off
  double max_vertical_px = 50.0;         ///< |dv| gate; 0 = off
  double bin_width_px = 20.0;            ///< histogram bin width (stroll_bearnav: 20 px)
  int bin_count = 41;                    ///< odd; range is +-bin_width_px*bin_count/2 (stroll_bearnav: 41)
  double refine_window_px = 10.0;        ///< half-width of the inlier window around the refined peak
  int min_inliers = 6;                   ///< fewer inliers -> confidence 0
  int full_confidence_inliers = 30;      ///< inliers at which the count term of the confidence saturates
  double min_confidence = 0.25;          ///< estimates below are reported as not valid
  double horizontal_fov_deg = 60.0;      ///< camera horizontal field of view, for heading_correction_rad

  [[nodiscard]] Status validate() const;
  static const ParamSchema<HeadingParams>& schema();
};

/// One kept match: indices into the current features and the reference set, with positions.
struct FeatureMatch {
  int current_index = -1;
  int reference_index = -1;
  float distance = 0.0f;  ///< descriptor distance (Hamming bits or L2)
  float du_px = 0.0f;     ///< u(current) - u(reference)
  float dv_px = 0.0f;     ///< v(current) - v(reference)
  bool inlier = false;    ///< inside the refined histogram peak
};

/// Result of one estimate.
struct HeadingEstimate {
  double offset_px = 0.0;               ///< scene position in current minus reference (positive: moved right)
  double heading_correction_rad = 0.0;  ///< -atan(offset_px / focal_px), CCW positive
  int matches = 0;                      ///< matches that passed every gate (the histogram votes)
  int inliers = 0;                      ///< votes inside the refined peak
  double confidence = 0.0;              ///< [0, 1]
  /// Second histogram peak over the first, [0, 1]: the largest bin at least two bins away from the
  /// winning bin divided by the winning bin's count. 0: one clear offset; near 1: two offsets are
  /// equally supported (repeated structure, wrong place, or the scene changed). 1 when there are no
  /// votes at all (nothing supports any offset).
  double ambiguity = 1.0;
  bool valid = false;                   ///< confidence >= min_confidence
};

/// Reference features: descriptors (one row each, CV_8U or CV_32F) and the image position at which
/// each is expected. Non-owning; both must stay alive during estimate().
struct ReferenceView {
  cv::Mat descriptors;
  std::span<const cv::Point2f> positions_px;
};

/// Matches and votes; owns and reuses every per-frame buffer.
class HeadingEstimator {
 public:
  /// `params` must be valid (HeadingParams::validate()); invalid values are clamped to sane ones.
  explicit HeadingEstimator(const HeadingParams& params = {});

  [[nodiscard]] const HeadingParams& params() const { return params_; }
  /// Replaces the parameters (e.g. after live reconfiguration); buffers are kept.
  void set_params(const HeadingParams& params);

  /// Estimates the offset of `current` against `reference`. `image_width_px` (> 0) converts the
  /// offset to a heading with the horizontal FOV; with 0 the correction is reported as 0.
  /// Empty inputs give an ok, not-valid estimate with 0 matches. Errors (never a crash): keypoint
  /// and descriptor row counts differ, reference positions and descriptor rows differ, descriptor
  /// type not CV_8U/CV_32F, or reference and current descriptors differ in type or width.
  Result<HeadingEstimate> estimate(const ReferenceView& reference, const Features& current, double image_width_px);
  /// Convenience: a reference given as Features (positions = keypoint positions).
  Result<HeadingEstimate> estimate(const Features& reference, const Features& current, double image_width_px);

  /// Kept matches of the last estimate (valid until the next call).
  [[nodiscard]] std::span<const FeatureMatch> last_matches() const { return matches_; }
  /// Histogram of the last estimate (bin_count counts; bin i is centred on (i - bin_count/2)*bin_width_px).
  [[nodiscard]] std::span<const int> last_histogram() const { return histogram_; }

 private:
  Status match(const cv::Mat& reference, std::span<const cv::Point2f> reference_px, const Features& current);
  HeadingEstimate vote(double image_width_px);

  HeadingParams params_;
  std::vector<FeatureMatch> matches_;
  std::vector<int> histogram_;
  std::vector<int> reference_best_;     // per reference row: best current index (cross-check)
  std::vector<float> reference_best_d_; // per reference row: best distance
  std::vector<cv::Point2f> positions_;  // reference positions when given as Features
  std::vector<int> best_train_;         // per current row: best reference row
  std::vector<int> order_;              // reference rows sorted by v (vertical gate)
  std::vector<float> sorted_v_;
  std::vector<int> lo_, hi_;            // per current row: candidate range in the sorted reference
  cv::Mat sorted_desc_;                 // capacity buffer: reference descriptors sorted by v
  std::vector<float> best_d_, second_d_;
};

/// Brute-force best/second-best search shared by the estimator and the teacher: for each query row,
/// the best and second best train rows. `best_train` / `best_d` / `second_d` are resized to the
/// query count; `train_best_query` (optional) receives, per train row, its best query (-1 if none).
/// Descriptors must have equal type (CV_8U: Hamming, CV_32F: L2) and width; returns false otherwise.
bool knn2_bruteforce(const cv::Mat& query, const cv::Mat& train, std::vector<int>& best_train,
                     std::vector<float>& best_d, std::vector<float>& second_d, std::vector<int>* train_best_query,
                     std::vector<float>* train_best_d);

/// Checks a Features value: keypoints and descriptor rows agree, type CV_8U or CV_32F.
Status check_features(const Features& features, const char* what);

}  // namespace visnav::feature_replay
