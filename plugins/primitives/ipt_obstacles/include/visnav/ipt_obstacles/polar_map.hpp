// visnav IPT obstacles — the local polar map and the navigation decisions (thesis Ch. 4 and
// Ch. 6; spec §5, §7).
//
//  * The thesis's Ch. 4 goal-less roaming histogram is not implemented: no mission roams without a
//    goal (teach and repeat always has the edge's line), so the code had no node and no tree.
//  * NavigationFilter: the Ch. 6 goal-directed strategy. Contact points are stored in the
//    ground frame and re-expressed around the robot every cycle (30 sectors of 12°, sector k
//    covers bearings [−180° + 12k, −180° + 12(k+1))); only points closer than the goal count
//    (R_nf = |goal − robot|). Per cycle (spec §7.5):
//      S0 goal reached (R_nf < goal_tolerance_m): reset, stop;
//      S1 a point closer than security_distance_m (S_dist): potential-field direction, repelled
//         by each sector's nearest point within S_dist [ours: attracted by the middle of the gap ahead nearest
//         the goal direction, with the repulsion along it dropped, so that a gap narrower than
//         2·S_dist is entered; else by the last GO candidate's direction while tenacity is on,
//         else by the goal; a direction behind the robot keeps the side of the previous turn];
//      GF goal sector free: P_L/P_R the nearest points of the first occupied sectors left and
//         right; a gap narrower than gap_width_m is handled as GO; else with P_X the closer
//         (the one in front if the other is behind) and ε = asin(S_dist/d_X):
//         θ_mot = θ_goal if |θ_goal − θ_PX| > ε (6.3), else θ_PR + ε or θ_PL − ε; then reset;
//      GO goal sector occupied: two searches from the goal direction, counter-clockwise and
//         clockwise, over angularly consecutive stored points (Case 1 inside an occupied run,
//         Case 2 across a free run, Case 3 with one end behind the robot); a gap is permitted
//         when |P_L − P_R| > gap_width_m and d_X > S_dist; θ_mot = θ_PX ∓ ε towards the far
//         end; a candidate whose sector holds a point nearer than S_dist + step_m is rejected.
//         Side: the tenacity side once chosen, else the smaller deviation from the goal.
//         [ours] The searches walk on past pairs whose ends are both behind the robot (they are
//         not candidates): with the goal behind the robot they used to stop at the first pair,
//         and a robot inside a U turned in place for ever.
//         No candidate: rotate in place (no translation) with a reason.
//      S9 no stored point ahead (|α| < 90°) any more: reset (the obstacle is passed).
//    [spec I] simplification: the "current obstacle" of the reset test is every stored point.
//    [ours] Stored points are merged per merge_cell_m square cell (the newest sighting kept).
//
// Frames: points and poses in one ground frame (odom or world), metres; bearings and θ_mot in
// the robot frame, radians, CCW positive, 0 = heading. Pure; no clock, no I/O.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct PolarMapParams {
  double sector_width_deg = 12.0;     ///< γ, thesis Ch. 6 (30 sectors)
  double security_distance_m = 0.95;  ///< S_dist, thesis Ch. 6
  double gap_width_m = 0.95;          ///< W_gap (the thesis experiments; 2·S_dist = 1.90 m by its rule text)
  double goal_tolerance_m = 0.15;     ///< [spec I]
  double step_m = 0.02;               ///< travel per cycle, for candidate validation [spec I]
  double repulsion_gain = 1.0;        ///< potential field [spec I]: Σ gain·(1/d − 1/S_dist)/d² away from points
  double attraction_gain = 1.0;       ///< potential field: gain · unit vector to the goal
  double reset_keep_near_m = 0.0;     ///< on a reset keep the points this close (spec §7.5 [I]
                                      ///< reset_keep_near; 0 = the thesis: forget everything)
  double merge_cell_m = 0.05;         ///< [ours] one stored point per cell of this side, the newest
                                      ///< (0 = keep every sighting; the map then grows every cycle)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<PolarMapParams>& schema();
};

enum class Situation : std::uint8_t {
  goal_reached,   ///< S0
  high_risk,      ///< S1 potential field
  goal_free,      ///< S2 GF, straight to the goal
  goal_grazing,   ///< S3 GF, deviate from the closer point
  gap,            ///< S5/S6 GO through a gap between two points
  gap_end_behind, ///< S7 GO, one end behind the robot
  no_candidate,   ///< GO found nothing: rotate in place
  blocked,        ///< S10: no free run wide enough: stop
};
[[nodiscard]] const char* to_string(Situation situation);

struct Decision {
  Situation situation = Situation::blocked;
  double heading_rad = 0.0;   ///< θ_mot, robot frame (CCW +)
  bool translate = false;     ///< false: stop (goal reached, blocked) or rotate in place (no candidate)
  bool reset = false;         ///< the filter and tenacity were reset this cycle
  std::string reason;         ///< one line for logs
};

/// Ch. 6 navigation filter with tenacity. Not thread-safe; one per controller.
class NavigationFilter {
 public:
  explicit NavigationFilter(PolarMapParams params) : params_(params) {}

  /// Adds this cycle's contact points (ground frame).
  void add_points(std::span<const cv::Point2d> points_m);
  /// One decision (spec §7.5) for the robot at `robot` heading to `goal_m`.
  [[nodiscard]] Decision decide(const Pose2D& robot, const cv::Point2d& goal_m);
  /// Clears the points (but those within reset_keep_near_m of `robot`) and tenacity.
  void reset(const Pose2D& robot);
  void reset();

  [[nodiscard]] const std::vector<cv::Point2d>& points() const { return points_; }
  [[nodiscard]] bool tenacity_on() const { return tenacity_on_; }
  [[nodiscard]] int tenacity_side() const { return tenacity_side_; }  ///< +1 CCW (left), −1 CW (right)
  /// Sector index of a bearing (robot frame).
  [[nodiscard]] int sector_of(double bearing_rad) const;
  [[nodiscard]] int sector_count() const;

 private:
  PolarMapParams params_;
  std::vector<cv::Point2d> points_;
  bool tenacity_on_ = false;
  std::unordered_map<std::int64_t, std::size_t> cell_index_;  // merge cell -> index in points_
  [[nodiscard]] std::int64_t cell_of(const cv::Point2d& p) const;
  void reindex();
  int tenacity_side_ = 1;
  double tenacity_heading_world_rad_ = 0.0;  // the last GO candidate's direction, ground frame
  int rotate_side_ = 0;
  int field_side_ = 0;   // side of a potential-field turn towards a direction behind the robot  // side of an ongoing in-place rotation without tenacity (0 = none)
};

}  // namespace visnav::ipt
