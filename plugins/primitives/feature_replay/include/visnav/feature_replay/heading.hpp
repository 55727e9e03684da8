// feature_replay core — descriptor matching and histogram-voting heading estimation. The estimator
// is in the SDK (visnav/histogram_voting.hpp) so that relocalisation shares it.
#pragma once

#include "visnav/histogram_voting.hpp"

namespace visnav::feature_replay {

/// The confidence gate of `visnav align`, calibrated on appearance change (issue 36,
/// docs/feature_replay.md section 7): on the seed-1 pair sets, estimates with confidence below
/// 0.075 were wrong more often than right (13 of 31 correct, star_brief + orb + akaze), those
/// above right in at least two thirds of each band. The replay (ReplayFeatureEdge's
/// `min_confidence` port) and `train-descriptor` keep the SDK's HeadingParams default (0.25): with
/// 0.075 a replay in the wrong world steered on spurious glimpses past its lost bound.
inline constexpr double kCalibratedMinConfidence = 0.075;

/// HeadingParams{} with the calibrated gate of `visnav align`.
[[nodiscard]] inline HeadingParams calibrated_heading_params() {
  HeadingParams p;
  p.min_confidence = kCalibratedMinConfidence;
  return p;
}

}  // namespace visnav::feature_replay
