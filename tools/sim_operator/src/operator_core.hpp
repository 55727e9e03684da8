// The scripted operator: drives a simulated robot along a route's waypoints the way a person
// teaching a route for seed 000 would — straight legs, stop at each waypoint, turn in place to
// the next leg, drive on — and says which primitive each leg is taught with. It sees the true
// pose (it is the human), never the odometry.
//
// A robot that cannot turn on the spot (car-like, min_turning_radius_m > 0) is driven through
// each corner on an arc of that radius instead: the turn starts d = R·tan(|θ|/2) before the
// waypoint (θ the corner's turn) and ends d after it on the next leg, so the taught path is a
// drivable curve. Nothing is taught on the arc (primitive empty): the map gets its node where
// the arc starts and the next edge starts where it ends, and FollowRoute's arc turn
// (min_turning_radius_m) drives the same arc between them. On a closed route the first d of the
// first leg is driven without teaching as well, so the first edge starts where the closing arc
// into it ends (every lap after the first arrives there).
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
  /// 0: turn in place at each waypoint. > 0: the robot cannot turn tighter than this radius
  /// (car-like), corners are driven as arcs of this radius (see the file comment), m.
  double min_turning_radius_m = 0.0;
  double arc_speed_mps = 0.3;            ///< forward speed on a corner arc (<= speed_mps)

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
  /// Arc mode: leg i's first lead_in_m(i) and last lead_out_m(i) metres are (part of) corner
  /// arcs, not taught. 0 when turning in place.
  [[nodiscard]] double lead_in_m(std::size_t leg) const { return lead_in_m_.at(leg); }
  [[nodiscard]] double lead_out_m(std::size_t leg) const { return lead_out_m_.at(leg); }

 private:
  [[nodiscard]] bool arcs() const { return params_.min_turning_radius_m > 0.0; }
  /// Arc command towards `heading_error` (target − current, wrapped); zero once within tolerance.
  [[nodiscard]] Twist arc_command(double heading_error) const;

  std::vector<OperatorLeg> legs_;
  std::vector<double> lead_in_m_;
  std::vector<double> lead_out_m_;
  OperatorParams params_;
  std::size_t leg_ = 0;
  bool turning_ = true;
  bool done_ = false;
  bool closed_ = false;
  bool closing_ = false;
};

/// The distances d = R·tan(|θ|/2) each corner arc of radius `min_turning_radius_m` takes off the
/// legs either side of it (lead-in of leg i: the arc from the previous leg; lead-out: the arc
/// into the next; the last leg of an open route has no lead-out, the first none lead-in).
/// Error (code out_of_range, key min_turning_radius_m): a corner of more than 170° or a leg too
/// short for its two arcs (the message names the leg and the distances).
struct LegArcs {
  std::vector<double> lead_in_m;
  std::vector<double> lead_out_m;
};
[[nodiscard]] Result<LegArcs> leg_arcs(const std::vector<OperatorLeg>& legs, bool closed, double min_turning_radius_m);

/// Legs between consecutive waypoints (and back to the first when `closed`), with kinds mapped
/// through `kind_map` ("feature" → "feature_segment", ...). `force_kind` (if not empty)
/// replaces every leg's kind (e.g. a feature-only map of the same route).
[[nodiscard]] Result<std::vector<OperatorLeg>> make_legs(const std::vector<cv::Point2d>& waypoints,
                                                         const std::vector<std::string>& waypoint_kinds, bool closed,
                                                         const std::vector<std::pair<std::string, std::string>>& kind_map,
                                                         const std::string& force_kind);

}  // namespace visnav::simop
