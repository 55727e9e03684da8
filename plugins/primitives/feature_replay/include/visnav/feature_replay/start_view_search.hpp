// Start-view search of ReplayFeatureEdge (docs/feature_replay.md, "ReplayFeatureEdge"): at the start
// of an edge, look for the taught start view by turning in place.
#pragma once

#include <array>
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
  /// How far from the odometric heading the start view is expected, rad (sd of a Gaussian
  /// prior on the turn; 0 = every heading of the scan alike). The scan's scores are weighted by
  /// it: the odometric heading at a node is off by the turn's odometry error and, at the node
  /// that closes a loop, the loop's heading drift (a few degrees on the simulated robots, some
  /// 10 deg on a real one), not by 50 deg.
  double prior_sd_rad = 20.0 * std::numbers::pi / 180.0;
  static constexpr double kHeadingMarginRad = 0.25;  ///< room for the edge's own steering after the search
  /// A scan is ambiguous when a heading at least this far from its likeliest peak also scored at least
  /// `kAmbiguityRatio` of the best: the scene repeats (a tiled wall, a row of equal facades), so
  /// the best is no more the view than the other one and the robot keeps its odometric heading.
  static constexpr double kAmbiguitySeparationRad = 20.0 * std::numbers::pi / 180.0;
  static constexpr double kAmbiguityRatio = 0.8;
};

/// When the first frames of an edge do not see the taught start view, the robot turns in place
/// left then right by up to the scan range, remembers the heading with the best match, turns
/// there and looks again standing still (the same test as the first look); only a view that
/// passes that second look is driven to, otherwise the robot turns back and starts on the
/// odometric heading and the lost policy decides. An odometric turn at a node carries the teach
/// run's heading drift (e.g. the turn that closes a loop: the whole loop's drift); this finds the
/// view instead. The look must see the view near the image centre (max_offset): a view 40 deg off
/// still overlaps a 60 deg camera's image enough for a confident match. The scan keeps the heading
/// peak (a heading matching best within 10 deg) whose match is most confident and most centred,
/// weighted by how far it is from the odometric heading (`prior_sd_rad`).
///
/// Why the second look: while turning, single frames (motion blur, a facade that repeats) give
/// confident matches that are not the view; a real view is still there when the robot stops. Why
/// the range is bounded by the heading check: a view found beyond it ends the edge as lost on its
/// first frame (measured on the campus route, winter, seed 3: a 74 deg false match at e13).
///
/// Why the ambiguity test: where the scene repeats, the second look confirms a wrong view as
/// readily as the right one (measured on generated indoor halls with tiled brick walls: a view
/// 52 deg off the odometric heading confirmed, and the robot drove into the hall wall). A view
/// that is the start view is the only heading of the scan that matches that well.
///
/// With the scan off (`scan_rad` 0) the first three frames of an edge started at its beginning
/// are still looked at while driving: a start view not seen is warned about (the robot may have
/// been started away from the taught start), and the edge is driven.
///
/// Headings are odometry-frame radians; the search unwraps them itself. Not thread-safe (one per
/// replayer).
class StartViewSearch {
 public:
  /// Only an edge started at (within 0.3 m of) its beginning searches its start view.
  void begin(const StartViewSearchParams& params, double started_m);
  [[nodiscard]] bool searching() const { return phase_ != Phase::driving; }
  /// Standing still to look (the first look or the second); false while only watching (scan off).
  [[nodiscard]] bool probing() const { return phase_ == Phase::probe || phase_ == Phase::confirm; }
  /// The scan range this search uses (the port's, bounded by the heading check), rad.
  [[nodiscard]] double scan_rad() const { return scan_rad_; }

  /// One frame: the turn command while searching, nullopt once driving (and while watching). `informative`: the map
  /// holds something to see at the start (where it does not, e.g. open grass, there is no view to
  /// search for). `offset_fraction`: |offset| of the match over the image width.
  std::optional<Twist> update(double heading_rad, double confidence, double offset_fraction, bool informative,
                              Logger& logger, const std::string& who, const std::string& edge_id);

 private:
  enum class Phase : std::uint8_t { watch, probe, scan_left, scan_right, turn_to_best, confirm, turn_back, driving };
  /// One frame of the scan: the turn it was seen at, its score and its match confidence.
  struct ScanSample {
    float turn_rad = 0.0F;
    float score = 0.0F;
    float confidence = 0.0F;
  };
  static constexpr double kPeakWindowRad = 10.0 * std::numbers::pi / 180.0;  ///< a peak is the best within this
  [[nodiscard]] double prior(double turn_rad) const;
  [[nodiscard]] bool is_peak(std::size_t i) const;
  /// Sets best_* to the likeliest peak of the scan (score x prior) and returns the best score at
  /// least kAmbiguitySeparationRad from it (-1 if none) and its turn.
  void choose_best(double& runner_up_score, double& runner_up_turn_rad);
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
  // The scan's frames (fixed storage: a +-75 deg scan at 0.4 rad/s is about 100 frames at 10 Hz;
  // frames beyond the capacity are not recorded).
  std::array<ScanSample, 1024> samples_{};
  std::size_t sample_count_ = 0;
};

}  // namespace visnav::feature_replay
