// Scoring of labelled image pairs for `visnav align --pairs` (issue 36): the evaluation protocol
// of GRIEF (Krajník et al. 2017, "Image features for visual teach-and-repeat navigation in
// changing environments"): a pair is wrong when its offset is more than tolerance_px off the
// label or when there is no estimate. Besides that error rate, the score reports the refusal
// rate (pairs without an estimate) and the error rate among the answered pairs, and the gate
// curve sweeps the confidence threshold to show coverage against precision.
//
// Pure functions over the per-pair outcomes; no I/O.
#pragma once

#include <span>
#include <vector>

namespace visnav::feature_replay {

/// What the estimator gave for one labelled pair.
struct PairOutcome {
  bool estimated = false;   ///< an offset was computed (false: the pair failed or no votes at all)
  double offset_px = 0.0;   ///< estimated offset (meaningful when estimated)
  double confidence = 0.0;  ///< the estimate's confidence (0 below min_inliers)
  double shift_px = 0.0;    ///< the label
};

/// The figures of one operating point. Rates are fractions in [0, 1].
struct AlignScore {
  double min_confidence = 0.0;  ///< the gate of this point
  int pairs = 0;
  int answered = 0;             ///< estimated and confidence > 0 and >= min_confidence
  int refused = 0;              ///< pairs - answered
  int wrong = 0;                ///< refused + wrong_answered (GRIEF: no estimate counts as wrong)
  int wrong_answered = 0;       ///< answered with |offset - shift| > tolerance_px
  double error_rate = 0.0;      ///< wrong / pairs (0 when there are no pairs)
  double refusal_rate = 0.0;    ///< refused / pairs, i.e. 1 - coverage
  double coverage = 0.0;        ///< answered / pairs
  /// wrong_answered / answered; NaN when nothing was answered.
  double answered_error_rate = 0.0;
  /// 1 - answered_error_rate (correct among answered); NaN when nothing was answered.
  double precision = 0.0;
};

/// True when the pair is answered at gate `min_confidence`: the rule of HeadingEstimate::valid
/// (confidence > 0 and confidence >= min_confidence), so a sweep reproduces `--set min_confidence`.
bool answered_at(const PairOutcome& outcome, double min_confidence);

/// Scores `outcomes` at one gate.
AlignScore score_pairs(std::span<const PairOutcome> outcomes, double min_confidence, double tolerance_px);

/// Scores at the gates 0, 1/steps, ..., 1 (steps >= 1; fewer are taken as 1): steps + 1 points,
/// coverage non-increasing along the curve.
std::vector<AlignScore> gate_curve(std::span<const PairOutcome> outcomes, int steps, double tolerance_px);

}  // namespace visnav::feature_replay
