// visnav IPT obstacles — the detour of a replay around an obstacle on the taught line ([ours];
// issue 16, docs/obstacles.md "Replay with avoidance").
//
// The Ch. 6 strategy (polar_map.hpp) steers between stored contact points one decision at a
// time; with the few points a wide obstacle yields (contacts come from vertical borders only,
// spec §4.3) it drives into gaps inside a van and swings between its ends (measured: 1 of 6 van
// positions passed). A replay knows more: the line it must return to. LaneDetour keeps every
// obstacle point of the detour in the line's frame (s along the line from where the detour
// began, l to the left) and drives along the line at a lateral offset (a "lane") that no point
// near the robot's stretch of the line occupies:
//  * a lane l is free when no point with s in [s_robot − behind_m, s_robot + lookahead_m] has
//    |l_point − l| < body_radius_m + clearance_m. behind_m stands for the obstacle's unseen
//    length: the camera sees an obstacle's near face, rarely its side (measured: with 0.8 m the
//    robot turned back into a parked van's side). Before the line's end (end_s_m, the edge's
//    end) the robot must be back: a point holds it only until end_s_m − return_m (but at least
//    min_behind_m past the point), and never before the body (radius + clearance) is past the
//    point: the far end of an obstacle's side seen while turning out holds the robot in its lane
//    until the body has cleared it, also once it is out of view behind the robot;
//  * a point's clearance grows with the travel along the line since it was seen, d: by
//    min(max_drift_m, 0.5·drift_rad_per_m·d²), the lateral error a heading drift of the odometry
//    puts between the robot and points it no longer sees (campus seed 5: 0.07 rad of drift over
//    a 6.8 m pass, the robot's true offset 0.34 m nearer the van's side than its odometry said);
//    The margin widens the lane but never closes a side by itself: a side with no free lane
//    with the margins is searched again without them (session 15: on van_path the margin of a
//    point 1.5 m right of the line grew to 0.4 m beside the van and closed the right side 1.2 m
//    past the van's front, the robot stopping there);
//  * the robot returns towards the line (or a nearer lane) only when the whole band its body
//    sweeps on the way is free of held points;
//  * target: the line itself (l = 0) when free, else the free lane nearest to it on the side
//    chosen at the first blocked decision (the other side only when that side has none); a
//    free current target is kept (no swinging). Within commit_m of an obstacle point (ahead of
//    the robot or beside it) the chosen side is kept even when it closes: crossing to the other
//    side there would swing the body across the obstacle's face (measured: a van's rear corner
//    hit 1.3 m after such a switch); the decision is then blocked, with the reason;
//  * recovery from a closed side (max_recoveries, session 15): when the chosen side closes
//    within commit_m of the obstacle and the other side has a free lane, the decision is
//    `reverse` instead of `blocked`: the robot backs along the way it came (the lateral offsets
//    it drove at, aim_ahead_m behind it; the line itself before the detour's start) until no point lies between its body's back and recover_clear_m ahead, then takes the other
//    side with every point known, and keeps that side (it is not swapped back). Blocked with the
//    reason when both sides close, when the recoveries are used up, or after max_reverse_m of
//    reversing without the obstacle getting far enough ahead;
//  * steering: towards the point aim_ahead_m further along the line at the target offset;
//  * guard (session 17): the body never drives into a known point. A point up to guard_reach_m
//    beyond the body's front within body_radius_m + guard_margin_m of the robot's heading holds
//    the forward travel (`hold_forward`: turn in place); when the steering's direction has such a
//    point too, the nearest direction (within guard_max_turn_rad of the line's, towards the
//    target lane first) without one is steered to; none: blocked with the reason (campus seed 6:
//    a detour widening its lane towards a pillar ran into it; seed 3: turning out 2.3 m in front
//    of a van's rear, its side met the corner);
//  * done when the line is free, the robot is back on it (|l| < done_offset_m, heading within
//    done_heading_rad of the line) and has covered min_progress_m, or at the line's end;
//  * blocked (no free lane within ±max_offset_m): the decision says so, with the reason.
// Frames: points and poses in one ground frame (odom), metres, radians (CCW +). Pure; not
// thread-safe; one per detour.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct LaneDetourParams {
  double body_radius_m = 0.25;   ///< robot disc
  double clearance_m = 0.35;     ///< free space kept beyond the body
  double lookahead_m = 3.0;      ///< points this far ahead along the line constrain the lane
  double behind_m = 6.5;         ///< ... and this far behind the robot (the obstacle's unseen length: a van is 4.8 m, measured)
  double min_behind_m = 0.8;     ///< at least this far, whatever end_s_m says
  double end_s_m = 1e9;          ///< the line ends here (s from the detour start): the edge's end
  double return_m = 2.0;         ///< travel kept for getting back onto the line before end_s_m
  double max_offset_m = 2.5;     ///< widest lane searched on either side
  double offset_step_m = 0.05;   ///< lane search resolution
  double aim_ahead_m = 1.2;      ///< pursuit point along the line
  double done_offset_m = 0.1;    ///< back on the line: |l| below this ...
  double done_heading_rad = 0.15;  ///< ... and heading within this of the line's
  double min_progress_m = 0.5;   ///< along-line travel before the detour may end
  double commit_m = 2.0;         ///< the chosen side is kept within this of an obstacle point ahead; 0 = off
  double drift_rad_per_m = 0.012;  ///< odometry heading drift assumed while passing blind: clearance grows by 0.5·drift·d²
  double max_drift_m = 0.4;      ///< ... (d: travel along the line since the point was seen) up to this; 0 = off
  int max_recoveries = 1;        ///< closed side within commit_m: reverse and take the other side this often; 0 = stop (session 13)
  double recover_clear_m = 3.0;  ///< reverse until no obstacle point is this close ahead (or beside the body)
  double max_reverse_m = 10.0;   ///< most reversing along the line per recovery; then blocked
  double guard_reach_m = 0.3;    ///< no forward travel while a point lies this far ahead of the body's front in its band; 0 = off
  double guard_margin_m = 0.05;  ///< the band: body_radius_m + this either side of the heading
  double guard_max_turn_rad = 1.6;  ///< the guard's search for a free heading, either way from the line's

  [[nodiscard]] Status validate() const;
  static const ParamSchema<LaneDetourParams>& schema();
};

struct LaneDecision {
  enum class Kind : std::uint8_t { drive, done, blocked, reverse };
  Kind kind = Kind::drive;
  double heading_rad = 0.0;  ///< direction to drive in, robot frame (CCW +); reverse: the turn that makes reversing follow the way it came
  bool hold_forward = false; ///< drive: a known point lies in the body's way straight ahead: turn in place to heading_rad
  double lane_m = 0.0;       ///< target lateral offset (left +)
  double s_m = 0.0;          ///< robot along the line from the detour start
  double l_m = 0.0;          ///< robot's lateral offset
  std::string reason;        ///< one line for logs
};

class LaneDetour {
 public:
  /// `line_start`: where the detour began; its heading is the line's direction. Params must validate().
  LaneDetour(LaneDetourParams params, const Pose2D& line_start) : params_(params), start_(line_start) {}

  /// Adds obstacle points (ground frame); they are kept for the whole detour.
  void add_points(std::span<const cv::Point2d> points_m);
  [[nodiscard]] LaneDecision decide(const Pose2D& robot);
  [[nodiscard]] std::size_t point_count() const { return points_.size(); }
  /// Recoveries (reverse, then the other side) begun so far.
  [[nodiscard]] int recoveries() const { return recoveries_; }
  [[nodiscard]] bool reversing() const { return reversing_; }
  /// Sets the side (+1 left, −1 right) taken at the first blocked decision, before any: an
  /// obstacle's full width known beyond the lookahead (face_extent.hpp). 0 leaves it open.
  void prefer_side(int side) { side_ = side > 0 ? 1 : (side < 0 ? -1 : 0); }

 private:
  [[nodiscard]] cv::Point2d to_line(double x_m, double y_m) const;  // (s, l)
  /// `drift`: with the drift margin (false: body radius + clearance only).
  [[nodiscard]] bool lane_free(double lane_m, double s_robot_m, bool drift = true) const;
  /// No held point in the band the body sweeps from lateral offset from_m (the robot) to to_m
  /// (plus the clearance beyond to_m).
  [[nodiscard]] bool sweep_free(double from_m, double to_m, double s_robot_m) const;
  /// How far behind the robot point i still holds: behind_m cut for the line's end, never less
  /// than min_behind_m nor the body radius + clearance.
  [[nodiscard]] double hold_m(std::size_t i) const;
  [[nodiscard]] bool held(std::size_t i, double s_robot_m) const;
  /// Body radius + clearance + the drift margin of point i with the robot at s_robot_m.
  [[nodiscard]] double half_m(std::size_t i, double s_robot_m, bool drift = true) const;
  /// An obstacle point at most commit_m ahead of the robot or beside it (still holding a lane).
  [[nodiscard]] bool near_obstacle(double s_robot_m) const;
  /// No obstacle point from the body's back (radius + clearance behind) to recover_clear_m ahead.
  [[nodiscard]] bool clear_to_cross(double s_robot_m) const;
  [[nodiscard]] std::string closes_reason(int side) const;
  /// The lateral offset the robot drove at when it last passed s_m going forward (0 before the detour).
  [[nodiscard]] double came_at(double s_m) const;
  /// A point in the body's band up to guard_reach_m beyond its front, driving from (s_m, l_m) in
  /// direction `dir_on_line_rad` (relative to the line).
  [[nodiscard]] bool way_blocked(double s_m, double l_m, double dir_on_line_rad) const;

  // The steps of decide(); `r` is the robot in the line's frame (s, l), `heading_on_line` its
  // heading relative to the line. A step returning true has made the decision `d` final.
  /// While reversing (a recovery): far enough before every point, switch to the other side for
  /// good and return false (the lane is chosen as usual); else reverse on, or blocked after
  /// max_reverse_m.
  [[nodiscard]] bool reverse_decided(const cv::Point2d& r, double heading_on_line, LaneDecision& d);
  /// The target lane: the line when it and the sweep back to it are free, else the kept free
  /// target, else choose_side_lane(). `lane` stays empty when no lane is free.
  [[nodiscard]] bool choose_lane(const cv::Point2d& r, double heading_on_line, std::optional<double>& lane,
                                 LaneDecision& d);
  /// The free lane nearest the line on `side` (+1 left, −1 right), with the drift margin; without
  /// one, the lane free of body radius + clearance nearest the robot's offset.
  [[nodiscard]] std::optional<double> nearest_free_lane(int side, const cv::Point2d& r) const;
  /// Both sides searched: the chosen side's lane first; a closed side near the obstacle starts a
  /// recovery (reverse) or blocks the detour.
  [[nodiscard]] bool choose_side_lane(const cv::Point2d& r, double heading_on_line, std::optional<double>& lane,
                                      LaneDecision& d);
  /// The drive decision towards `lane`, with the guard (a free direction round a known point in
  /// the way, else blocked).
  void steer_to_lane(const cv::Point2d& r, double heading_on_line, double lane, LaneDecision& d) const;
  /// The direction nearest `aim_line` (relative to the line) within guard_max_turn_rad of the
  /// line's that no known point blocks, `toward` (+1/−1) first; none: nullopt.
  [[nodiscard]] std::optional<double> free_direction(const cv::Point2d& r, double aim_line, double toward) const;

  LaneDetourParams params_;
  Pose2D start_;
  std::vector<cv::Point2d> points_;  // (s, l)
  std::vector<double> seen_s_;       // per point: the robot's s when it was added
  double s_now_ = 0.0;               // the robot's s at the last decide()
  int side_ = 0;                     // +1 left, −1 right, 0 not chosen yet
  double lane_m_ = 0.0;
  int recoveries_ = 0;
  bool reversing_ = false;
  bool side_locked_ = false;     // after a recovery: the other side is not taken again
  double reverse_from_s_m_ = 0.0;
  std::vector<cv::Point2d> track_;  // (s, l) of the robot at each forward decision: the way it came
};

}  // namespace visnav::ipt
