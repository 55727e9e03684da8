// visnav IPT obstacles — camera height and pitch for the IPT from frames of flat ground
// (issue 16, `visnav calibrate-ipt`).
//
// Every feature tracked between two frames of flat, obstacle-free ground is a ground point, so
// its two IPT projections (with each frame's odometry pose) coincide when height and pitch are
// right: the discrepancy D (4.9) is zero. A wrong height scales every projection (D grows with
// the baseline), a wrong pitch bends them (D grows with range). The least squares are taken in
// pixels, not on D in metres: the IPT point of a track in one frame is projected (DPT) into the
// other and compared with the tracked pixel, both ways (symmetric transfer error). Minimising
// D² itself is biased under tracking noise (a lower camera shrinks every D, noise included:
// measured 5 cm and 6° off at 0.3 px noise). NLopt BOBYQA, bounded: height in [0.05, 5] m,
// pitch in [−1.4, 0.5] rad; errors are capped at max_transfer_px (also the cost of a track that
// does not meet the ground under a candidate) so a few bad tracks cannot dominate.
// The other intrinsics and the mounting offsets are taken as given.
// Pure; deterministic for a given input.
#pragma once

#include <span>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

/// Tracks between two frames and the odometry poses of both.
struct CalibrationPair {
  Pose2D pose_a;
  Pose2D pose_b;
  std::vector<cv::Point2f> pixels_a;
  std::vector<cv::Point2f> pixels_b;
};

struct CalibrationOptions {
  double max_transfer_px = 10.0;   ///< cap of a track's transfer error (robustness)
  int max_evaluations = 2000;
  double tolerance = 1e-10;        ///< relative tolerance on the parameters
  int min_tracks = 20;             ///< fewer usable tracks in total: error
};

struct CalibrationResult {
  double height_m = 0.0;
  double pitch_rad = 0.0;
  double rms_discrepancy_m = 0.0;  ///< RMS of D at the optimum, over the tracks that meet the ground
  double initial_rms_discrepancy_m = 0.0;
  int tracks = 0;
  int evaluations = 0;
};

/// Estimates height_m and pitch_rad of `initial` (its other fields are kept). Errors:
/// invalid_value (mismatched tracks, fewer than min_tracks tracks, pairs without baseline),
/// out_of_range (the result sees no ground), unspecified (NLopt failed).
[[nodiscard]] Result<CalibrationResult> calibrate_height_pitch(const IptCamera& initial,
                                                               std::span<const CalibrationPair> pairs,
                                                               const CalibrationOptions& options = {});

}  // namespace visnav::ipt
