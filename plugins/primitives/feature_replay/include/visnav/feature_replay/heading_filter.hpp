// Temporal filter of the histogram votes over consecutive frames (issue 36, part 3).
//
// A single frame's vote histogram (HeadingEstimator::last_histogram()) may hold too few votes to
// pass the confidence gate (seasonal change leaves a handful of correct matches), or a stray
// peak may win. Consecutive frames see the same scene from nearly the same heading, so their
// histograms agree once the rotation between them is taken out. HeadingHistogramFilter keeps an
// accumulated histogram A over the frames of one reference:
//
//     A_k = decay * shift(A_{k-1}, predicted_shift_px) + H_k
//
// where H_k is frame k's histogram and predicted_shift_px is how far the offset is expected to
// move from frame k-1 to k through the robot's own (odometric) rotation: a counter-clockwise
// rotation d_theta moves the scene right in the image, so offset_px grows by focal_px * d_theta
// (shift_px_for_rotation()). The shift is fractional: each bin's mass is split linearly between
// the two bins it lands on; mass shifted past either end is dropped. A predicted shift larger
// than max_shift_px (odometry glitch, a new reference) restarts the accumulation from H_k.
//
// The estimate is the accumulated peak: the winning bin (ties to the bin nearer zero), refined to
// the centre of mass of it and its two neighbours; votes = the mass of those three bins;
// confidence = min(1, votes / full_confidence_votes) * (1 - runner_up / peak) with runner_up the
// largest bin at least two bins from the peak (the estimator's rule, on accumulated mass);
// valid when votes >= min_votes and confidence >= min_confidence. With decay d a steady stream of
// v votes per frame converges to v / (1 - d) votes; after a real jump of the offset the new peak
// overtakes the old one once d^k < 1/2 (k = 2 frames for d = 0.7), see jump_frames().
//
// Units: pixels and radians. Not thread-safe (one per replayer). update() does not allocate after
// construction.
#pragma once

#include <span>
#include <vector>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::feature_replay {

/// Parameters of the temporal filter (config keys as named here).
struct HeadingFilterParams {
  double decay = 0.7;                 ///< weight kept from the accumulated histogram per frame, [0, 0.99]
  double max_shift_px = 200.0;        ///< a larger predicted shift restarts the accumulation, px
  double min_votes = 6.0;             ///< accumulated votes in the peak (3 bins) for a valid estimate
  double full_confidence_votes = 30.0;  ///< votes at which the count term of the confidence saturates
  double min_confidence = 0.25;       ///< estimates below are not valid

  [[nodiscard]] Status validate() const;
  static const ParamSchema<HeadingFilterParams>& schema();
};

/// The filtered estimate after one frame.
struct FilteredHeading {
  double offset_px = 0.0;   ///< refined accumulated peak, px (scene in current minus reference)
  double votes = 0.0;       ///< accumulated mass in the peak bin and its two neighbours
  double confidence = 0.0;  ///< [0, 1]
  double ambiguity = 1.0;   ///< runner_up / peak of the accumulated histogram (1: nothing accumulated)
  bool valid = false;
  bool restarted = false;   ///< this frame restarted the accumulation (first frame, reset, large shift)
};

/// Odometric shift of the offset for a counter-clockwise rotation `rotation_rad` between frames:
/// focal_px * rotation_rad with focal_px = (image_width_px / 2) / tan(hfov / 2). 0 if the width
/// or the field of view is not positive.
double shift_px_for_rotation(double rotation_rad, double image_width_px, double horizontal_fov_deg);

/// Frames after which a steady new peak of v votes per frame overtakes an old one that had
/// converged under the same v: the least k with decay^k < 1/2.
int jump_frames(double decay);

class HeadingHistogramFilter {
 public:
  /// `params` must be valid (HeadingFilterParams::validate()); bin_width_px > 0 and bin_count odd
  /// >= 1 describe the histograms given to update() (HeadingParams' bin_width_px and bin_count).
  HeadingHistogramFilter(const HeadingFilterParams& params, double bin_width_px, int bin_count);

  [[nodiscard]] const HeadingFilterParams& params() const { return params_; }
  /// Forgets the accumulation (a new reference, e.g. the next edge).
  void reset();

  /// Adds one frame's histogram (bin_count counts) after shifting the accumulation by
  /// `predicted_shift_px`. Error (accumulation unchanged): the histogram has another bin count,
  /// or the shift is not finite.
  Result<FilteredHeading> update(std::span<const int> histogram, double predicted_shift_px);

  /// The accumulated histogram after the last update (bin i centred on (i - bin_count/2) * bin_width_px).
  [[nodiscard]] std::span<const double> accumulated() const { return acc_; }

 private:
  void shift_accumulation(double shift_px);
  FilteredHeading estimate() const;

  HeadingFilterParams params_;
  double bin_width_px_;
  int bin_count_;
  bool empty_ = true;
  std::vector<double> acc_;
  std::vector<double> scratch_;
};

}  // namespace visnav::feature_replay
