// The scripted operator: drives a simulated robot along a route's waypoints the way a person
// teaching a route for seed 000 would — straight legs, stop at each waypoint, turn in place to
// the next leg, drive on — and says which primitive each leg is taught with. It sees the true
// pose (it is the human), never the odometry.
//
// Pure: one `update()` per control tick; no clock, no I/O. Thread-safety: single-threaded.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::simop {

struct OperatorParams {
  double speed_mps = 0.5;
  double heading_gain_per_s = 1.5;       ///< ω from heading error
  double cross_track_gain_per_ms = 0.8;  ///< ω from cross-track error (rad/s per m)
  double max_angular_radps = 0.6;
  double turn_tolerance_rad = 0.015;     ///< in-place turn done within this error
  double slow_down_m = 0.5;              ///< slow to 40 % within this distance of a waypoint

  [[nodiscard]] Status validate() const;
};

struct OperatorLeg {
  cv::Point2d from_m;
  cv::Point2d to_m;
  std::string kind;  ///< primitive (map edge kind) of this leg
};

/// What the operator does this tick.
struct OperatorAction {
  Twist command;
  std::string primitive;  ///< kind being taught now; empty while turning between legs
  bool done = false;      ///< all legs driven (and, on a closed route, the closing turn made)
  bool closing = false;   ///< closed route: every leg driven, turning in place to face the first leg
  int leg = 0;
};

class ScriptedOperatorCore {
 public:
  /// `closed`: the last leg ends where the first starts; after it the operator turns in place to
  /// face the first leg again (as a person closing a taught loop would), so the map can record
  /// that turn instead of deriving it from headings measured a whole loop apart.
  ScriptedOperatorCore(std::vector<OperatorLeg> legs, OperatorParams params, bool closed = false);
  /// Next action for the robot's true pose (world frame).
  OperatorAction update(const Pose2D& true_pose);
  [[nodiscard]] const std::vector<OperatorLeg>& legs() const { return legs_; }

 private:
  std::vector<OperatorLeg> legs_;
  OperatorParams params_;
  std::size_t leg_ = 0;
  bool turning_ = true;
  bool done_ = false;
  bool closed_ = false;
  bool closing_ = false;
};

/// Legs between consecutive waypoints (and back to the first when `closed`), with kinds mapped
/// through `kind_map` ("feature" → "feature_segment", ...). `force_kind` (if not empty)
/// replaces every leg's kind (e.g. a feature-only map of the same route).
[[nodiscard]] Result<std::vector<OperatorLeg>> make_legs(const std::vector<cv::Point2d>& waypoints,
                                                         const std::vector<std::string>& waypoint_kinds, bool closed,
                                                         const std::vector<std::pair<std::string, std::string>>& kind_map,
                                                         const std::string& force_kind);

}  // namespace visnav::simop
