// Start-view search of ReplayFeatureEdge (docs/feature_replay.md, "ReplayFeatureEdge"): at the start
// of an edge, look for the taught start view by turning in place.
#pragma once

#include <cstdint>
#include <numbers>
#include <optional>
#include <string>

#include "visnav/host.hpp"
#include "visnav/types.hpp"

namespace visnav::feature_replay {

/// Settings of one search (the node's ports and the lost policy's limits).
struct StartViewSearchParams {
  double scan_rad = 75.0 * std::numbers::pi / 180.0;  ///< turn at most this far left and right, rad (0 = off)
  double scan_speed_radps = 0.4;                            ///< turn rate while scanning, rad/s
  double max_offset = 0.15;      ///< a view counts as ahead when mean |offset| / image width is at most this
  double min_confidence = 0.2;   ///< the lost policy's: a view is seen at this mean confidence
  /// The lost policy's heading check (odometry against the taught heading, counted from the
  /// heading the edge started on; 0 = off). The scan stays `kHeadingMarginRad` inside it: a view
  /// found farther out would be refused by the lost policy as soon as the edge is driven.
  double max_heading_deviation_rad = 0.0;
  static constexpr double kHeadingMarginRad = 0.25;  ///< room for the edge's own steering after the search
};

/// When the first frames of an edge do not see the taught start view, the robot turns in place
/// left then right by up to the scan range, remembers the heading with the best match, turns
/// there and looks again standing still (the same test as the first look); only a view that
/// passes that second look is driven to, otherwise the robot turns back and starts on the
/// odometric heading and the lost policy decides. An odometric turn at a node carries the teach
/// run's heading drift (e.g. the turn that closes a loop: the whole loop's drift); this finds the
/// view instead. The look must see the view near the image centre (max_offset): a view 40 deg off
/// still overlaps a 60 deg camera's image enough for a confident match. The scan keeps the heading
/// whose match is most confident and most centred.
///
/// Why the second look: while turning, single frames (motion blur, a facade that repeats) give
/// confident matches that are not the view; a real view is still there when the robot stops. Why
/// the range is bounded by the heading check: a view found beyond it ends the edge as lost on its
/// first frame (measured on the campus route, winter, seed 3: a 74 deg false match at e13).
///
/// Headings are odometry-frame radians; the search unwraps them itself. Not thread-safe (one per
/// replayer).
class StartViewSearch {
 public:
  /// Only an edge started at (within 0.3 m of) its beginning searches its start view.
  void begin(const StartViewSearchParams& params, double started_m);
  [[nodiscard]] bool searching() const { return phase_ != Phase::driving; }
  [[nodiscard]] bool probing() const { return phase_ == Phase::probe || phase_ == Phase::confirm; }
  /// The scan range this search uses (the port's, bounded by the heading check), rad.
  [[nodiscard]] double scan_rad() const { return scan_rad_; }

  /// One frame: the turn command while searching, nullopt once driving. `informative`: the map
  /// holds something to see at the start (where it does not, e.g. open grass, there is no view to
  /// search for). `offset_fraction`: |offset| of the match over the image width.
  std::optional<Twist> update(double heading_rad, double confidence, double offset_fraction, bool informative,
                              Logger& logger, const std::string& who, const std::string& edge_id);

 private:
  enum class Phase : std::uint8_t { probe, scan_left, scan_right, turn_to_best, confirm, turn_back, driving };
  /// Three frames standing still: true once decided (`seen` says whether the view is ahead).
  bool look(double confidence, double offset_fraction, bool& seen, double& mean_confidence, double& mean_offset);
  void unwrap(double heading_rad);

  Phase phase_ = Phase::driving;
  StartViewSearchParams params_;
  double scan_rad_ = 0.0;
  double scan_last_rad_ = 0.0;      // previous heading (unwrapping)
  double scan_turned_rad_ = 0.0;    // unwrapped turn since the scan started
  double best_turn_rad_ = 0.0;
  double best_confidence_ = -1.0;
  double best_score_ = -1.0;        // confidence weighted by how centred the view is
  int look_frames_ = 0;
  double look_confidence_sum_ = 0.0;
  double look_offset_sum_ = 0.0;    // sum of |offset| / width (1 for a frame without a match)
};

}  // namespace visnav::feature_replay
