// feature_replay core — types shared by both replayers.
#pragma once

#include <cstdint>

namespace visnav::feature_replay {

/// What a replayer did this frame.
enum class ReplayState : std::uint8_t {
  steering,        ///< confident estimate; the correction was applied
  low_confidence,  ///< estimate below min_confidence: no correction (style A: omega 0; style B: recorded command)
  no_features,     ///< no current features or no reference features at this distance: no correction
  bad_input,       ///< inconsistent features (row counts, descriptor type/width): no correction
  finished,        ///< the edge (all laps) is done: zero command
};

[[nodiscard]] inline const char* to_string(ReplayState s) {
  switch (s) {
    case ReplayState::steering: return "steering";
    case ReplayState::low_confidence: return "low confidence";
    case ReplayState::no_features: return "no features";
    case ReplayState::bad_input: return "bad input";
    case ReplayState::finished: return "finished";
  }
  return "unknown";
}

}  // namespace visnav::feature_replay
