// visnav path following — the taught lateral position: where the path's middle lay in the view
// where the teacher drove.
//
// Control law (1) steers the path's middle to the image centre, so a replay drives the middle of
// the segmented path, which need not be where the teacher drove (a route script or an operator
// keeps to one side, the segmentation takes in a verge). Teach-and-repeat promises the taught
// line: the path teacher records, for every frame in which the path was seen, the follower's
// offsets at that odometric edge distance (VPF3 payload, visnav/path_payload.hpp), and the replay
// steers to the taught offset at its own edge distance (PathFollower::set_target_offset) instead
// of to 0.
//
// The profile is the samples' mean within ±window_m of the queried distance (the teacher's own
// heading wobble averages out over a window), times `gain` (0 = off: centre on the path as
// before; 1 = the taught offset). There is no target where no sample lies within the window (the
// path was not seen there at teach time, or the edge has no profile: a VPF1 / VPF2 payload) and
// where the samples' standard deviation exceeds max_sd: where the taught view changes quickly
// along the edge (a road or a junction coming into view ahead), a small along-track error of the
// replay would make the target wrong (the replay then holds its last target).
//
// Units: metres of the teach run's edge distance; offsets normalised as in path_follower.hpp
// ([-1, 1], + = path right of the image centre). Pure: no clock, no I/O; lookup O(log n + samples
// in the window), no allocation. Not thread-safe; one per edge replay.
#pragma once

#include <optional>
#include <vector>

#include "visnav/params.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/result.hpp"

namespace visnav::path_following {

struct TaughtOffsetParams {
  double gain = 0.0;      ///< share of the taught offset steered to; 0 = off (centre on the path)
  double window_m = 0.5;  ///< samples within this of the queried distance are averaged, m
  double max_sd = 0.03;   ///< no target where the window's samples spread more than this (normalised offset)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<TaughtOffsetParams>& schema();
};

class TaughtOffsetProfile {
 public:
  /// `samples` by non-decreasing distance (as decoded). Empty: never a target.
  TaughtOffsetProfile(const TaughtOffsetParams& params, std::vector<path_payload::OffsetSample> samples);

  /// The offset to steer to at taught edge distance `distance_m` (gain × the windowed mean of the
  /// plain or, with `junction`, the junction-mode offsets); nullopt when off, no sample is near
  /// or they spread more than max_sd.
  [[nodiscard]] std::optional<double> target(double distance_m, bool junction) const;
  /// The gain is on and the edge has a profile.
  [[nodiscard]] bool active() const { return params_.gain > 0.0 && !samples_.empty(); }
  [[nodiscard]] std::size_t size() const { return samples_.size(); }

 private:
  TaughtOffsetParams params_;
  std::vector<path_payload::OffsetSample> samples_;
};

}  // namespace visnav::path_following
