// Scoring of labelled pairs (see align_score.hpp).
#include "visnav/feature_replay/align_score.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace visnav::feature_replay {

bool answered_at(const PairOutcome& outcome, double min_confidence) {
  return outcome.estimated && outcome.confidence > 0.0 && outcome.confidence >= min_confidence;
}

AlignScore score_pairs(std::span<const PairOutcome> outcomes, double min_confidence, double tolerance_px) {
  AlignScore s;
  s.min_confidence = min_confidence;
  s.pairs = static_cast<int>(outcomes.size());
  for (const auto& o : outcomes) {
    if (!answered_at(o, min_confidence)) continue;
    ++s.answered;
    if (std::abs(o.offset_px - o.shift_px) > tolerance_px) ++s.wrong_answered;
  }
  s.refused = s.pairs - s.answered;
  s.wrong = s.refused + s.wrong_answered;
  if (s.pairs > 0) {
    s.error_rate = static_cast<double>(s.wrong) / s.pairs;
    s.refusal_rate = static_cast<double>(s.refused) / s.pairs;
    s.coverage = static_cast<double>(s.answered) / s.pairs;
  }
  if (s.answered > 0) {
    s.answered_error_rate = static_cast<double>(s.wrong_answered) / s.answered;
    s.precision = 1.0 - s.answered_error_rate;
  } else {
    s.answered_error_rate = std::numeric_limits<double>::quiet_NaN();
    s.precision = std::numeric_limits<double>::quiet_NaN();
  }
  return s;
}

std::vector<AlignScore> gate_curve(std::span<const PairOutcome> outcomes, int steps, double tolerance_px) {
  steps = std::max(1, steps);
  std::vector<AlignScore> curve;
  curve.reserve(static_cast<std::size_t>(steps) + 1);
  for (int i = 0; i <= steps; ++i)
    curve.push_back(score_pairs(outcomes, static_cast<double>(i) / steps, tolerance_px));
  return curve;
}

}  // namespace visnav::feature_replay
