// visnav navigation plugin — pure helpers behind the route nodes (PlanRoute, FollowRoute,
// TurnToAzimuth, TeachRoute, AtNode). No I/O, no clock; unit-tested directly.
//
// Frames: headings and azimuths are in the odom frame, radians, counter-clockwise positive.
// Thread-safety: free functions over values; MapStore is only read.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/map.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::nav {

/// Wraps an angle to (-pi, pi].
[[nodiscard]] double wrap_angle_rad(double angle_rad);

/// In-place turn controller (proportional with a minimum speed so the turn finishes despite
/// friction/dead-band, saturated at max_angular_radps).
struct TurnParams {
  double gain_per_s = 1.5;             ///< ω = gain · error
  double max_angular_radps = 0.6;
  double min_angular_radps = 0.08;     ///< |ω| floor while outside the tolerance
  double tolerance_rad = 0.02;         ///< turn is complete when |error| ≤ tolerance

  [[nodiscard]] Status validate() const;
};

/// Angular-velocity command for a remaining heading error (target − current, wrapped);
/// 0 when |error| ≤ tolerance.
[[nodiscard]] double turn_command_radps(double error_rad, const TurnParams& params);

/// Turning a robot that cannot turn on the spot (car-like): the heading change is driven as a
/// forward arc whose curvature never exceeds 1 / min_turning_radius_m.
struct ArcTurnParams {
  double min_turning_radius_m = 0.0;  ///< 0: turn in place (turn_command_radps); > 0: arc, m
  double speed_mps = 0.3;             ///< forward speed on the arc, m/s

  /// Errors (code out_of_range, key min_turning_radius_m / arc_speed_mps): negative or > 100 m
  /// radius, speed outside (0, 2] m/s.
  [[nodiscard]] Status validate() const;
  [[nodiscard]] bool arcs() const { return min_turning_radius_m > 0.0; }
};

/// Velocity command for a remaining heading error (target − current, wrapped) driven as an arc:
/// linear = speed_mps, |angular| = gain·|error| clamped to [min, max] of `turn` and never above
/// speed_mps / min_turning_radius_m (so |angular| / linear <= 1 / R); a zero twist once
/// |error| <= tolerance. With arc.min_turning_radius_m == 0: {0, turn_command_radps(...)}.
[[nodiscard]] Twist arc_turn_command(double error_rad, const TurnParams& turn, const ArcTurnParams& arc);

/// Heading change the robot must make at the node between two consecutive edges of a route:
/// the start azimuth of `next` minus the heading at the end of `previous` (edge statistic
/// "end_heading_rad" recorded while teaching; the previous edge's start azimuth if absent).
/// Relative turns are immune to the odometric heading drift accumulated since teaching.
[[nodiscard]] double turn_between_edges_rad(const EdgeRecord& previous, const EdgeRecord& next);

/// Edge statistic written by TeachRoute on the last edge of a closed route: the in-place turn
/// the operator made at the end of teaching, from that edge's end heading to facing the first
/// edge again, rad (left +). Measured by odometry over one turn, it is what a lap of the route
/// must turn between its last and first edge; the two edges' own headings were measured a whole
/// loop apart and differ by the loop's odometric heading drift as well.
inline constexpr const char* kClosingTurnStatistic = "closing_turn_rad";

/// Edge statistic written by TeachRoute: odometric distance the robot travelled between the end
/// of the previous edge and the start of this one while teaching (its stopping distance), m.
inline constexpr const char* kStartGapStatistic = "start_gap_m";

/// Along-track distance the robot has already covered of the next edge when that edge starts
/// (FollowRoute's `carried_m`): the previous edge's primitive stops only once the odometric
/// length is reached, so the robot starts the next edge `beyond_end_m` past the previous edge's
/// end (the last frame's overshoot plus the stopping distance). While teaching it also stopped
/// past the node, by `taught_gap_m`. The difference, projected onto the next edge's direction
/// (`turn_rad` between them; a 90° turn projects to 0), clamped to ±max_carry_m (>= 0).
[[nodiscard]] double carried_distance_m(double beyond_end_m, double taught_gap_m, double turn_rad,
                                        double max_carry_m);

/// Odometric distance scale of a replay against its teach run (FollowRoute's `distance_scale`):
/// odometric metres driven now per odometric metre recorded while teaching. Teach and replay
/// measure distance with different scale errors (tyre pressure, load, ground: the simulator draws
/// one per run, docs/sim.md), so an edge that ends on odometry ends short or long by that share of
/// its length; on the campus route that was the largest error left (docs/navigation.md, "Where
/// the hybrid error came from"). Visual along-track fixes (edges whose primitive moved its end,
/// `end_shift_m` != 0) say where the robot really is: a fix at cumulative taught distance T_i
/// (the sum of the route's taught edge lengths up to that node) was reached at odometric
/// distance D_i. The scale is the least-squares slope of D over T, over every fix since the
/// estimator was reset, once the fixes span `min_baseline_m` of taught distance (1 before; a
/// short span would turn the fixes' own errors of a few centimetres into a scale error); it is
/// clamped to 1 ± max_deviation. Pure; single-threaded.
struct DistanceScaleParams {
  double min_baseline_m = 20.0;  ///< taught distance the fixes must span before the scale is used, m (> 0)
  double max_deviation = 0.1;    ///< |scale − 1| clamp, (0, 0.5]
  [[nodiscard]] Status validate() const;
};
class DistanceScaleEstimator {
 public:
  explicit DistanceScaleEstimator(DistanceScaleParams params = {}) : params_(params) {}
  /// A visual fix: the node at cumulative taught distance `taught_m` was reached at odometric
  /// distance `odometry_m`. Non-finite values are ignored.
  void add_fix(double taught_m, double odometry_m);
  /// Forget every fix (the robot's position along the route is no longer continuous with them).
  void reset();
  /// Odometric metres per taught metre (1 until the fixes span min_baseline_m).
  [[nodiscard]] double scale() const;
  [[nodiscard]] int fixes() const { return n_; }

 private:
  DistanceScaleParams params_;
  int n_ = 0;
  double t0_ = 0.0, d0_ = 0.0;  ///< first fix (the sums are relative to it, for precision)
  double sum_t_ = 0.0, sum_d_ = 0.0, sum_tt_ = 0.0, sum_td_ = 0.0;
  double t_min_ = 0.0, t_max_ = 0.0;
};

/// A "kind=NodeID" table mapping edge kinds to the behaviour-tree node that handles them.
using KindMap = std::vector<std::pair<std::string, std::string>>;

/// Parses entries "kind=NodeID" (whitespace around names ignored). Errors name the bad entry.
[[nodiscard]] Result<KindMap> parse_kind_map(const std::vector<std::string>& entries);

/// NodeID for `kind`, or nullptr.
[[nodiscard]] const std::string* find_kind(const KindMap& map, std::string_view kind);

/// Parses entries "kind=multiplier" into a RouteCost (multiplier > 0; "inf" forbids a kind).
[[nodiscard]] Result<RouteCost> parse_kind_costs(const std::vector<std::string>& entries);

/// Route from the middle of edge `edge_id` to node `goal`: that edge, then the cheapest route from
/// its end node to `goal` (nothing more when it ends there). Used after relocalisation, when the
/// robot stands part-way along an edge. Errors: unknown edge or goal, no route from its end node.
[[nodiscard]] Result<Route> plan_from_edge(const MapStore& map, std::string_view edge_id, std::string_view goal,
                                           const RouteCost& cost = {});

/// The progress checkpoint FollowRoute keeps in the map folder with checkpoint="true": where the
/// mission is, as blackboard entries that `visnav run --resume` sets before the first tick
/// (trees/resume_route.xml relocalises with them as its odometry prior, then drives on to the goal).
inline constexpr const char* kProgressFile = "progress.yaml";
struct ProgressCheckpoint {
  std::string edge;          ///< resume_edge: the edge being driven
  double distance_m = 0.0;   ///< resume_distance_m: odometric distance along it
  std::string goal;          ///< resume_goal: the route's last node
};
/// The file text: a comment line, then "resume_edge: e3", "resume_distance_m: 1.250", "resume_goal: n0".
[[nodiscard]] std::string format_progress(const ProgressCheckpoint& progress);
/// Writes map_dir/progress.yaml crash-safely (temporary file, fsync, rename, folder fsync): a
/// crash leaves the previous checkpoint or the new one, never a torn file.
[[nodiscard]] Status write_progress(const std::string& map_dir, const ProgressCheckpoint& progress);
/// Removes map_dir/progress.yaml (a finished route leaves nothing to resume). Absent is fine.
[[nodiscard]] Status clear_progress(const std::string& map_dir);

/// Cheapest route from `node` back to itself through at least one edge (a closed patrol
/// route). Error when the node lies on no cycle.
[[nodiscard]] Result<Route> plan_cycle(const MapStore& map, std::string_view node, const RouteCost& cost = {});

}  // namespace visnav::nav
