// visnav IPT obstacles — when a stopped robot may cross the way of a walking person (issue 16:
// a person pacing across the campus square, docs/obstacles.md "Crossing policy").
//
// The frame difference of a standing camera (MotionWatch) says that something moves, not where
// it goes. A person pacing across the robot's line is out of the corridor most of the time, and
// the robot, which needs a few seconds to clear the person's lane, must not drive into it when
// the person is about to come back. [ours] Two pure parts:
//
//  * locate_moving(): the changed pixels of a frame difference over a band wider than the
//    corridor (MotionWatch::last_changed()) -> one ground point in the robot frame (x ahead,
//    y left): the median changed column, its lowest changed row (the feet), through the IPT
//    camera's back projection. Feet below the image (a person close ahead): the bottom row's
//    ground point at that column, flagged `contact_visible = false` (the person is at most that
//    far).
//  * CrossingPolicy: a track of those points over time (the last window_s seconds), a straight
//    line fitted to the lateral position y(t) and the range x(t) by least squares, and a
//    decision:
//      - lateral |y| within lane_half_width_m: in the robot's lane -> wait;
//      - walking towards the lane faster than min_speed_mps: arrival = (|y| - half width) /
//        speed; arrival < the time the robot needs to clear the lane -> wait, else go;
//      - walking away (or standing) at least away_clear_m beyond the lane's edge -> go; nearer
//        -> wait;
//      - no point for forget_s seconds: the track is dropped; `no_track` (the caller keeps its
//        own rule, e.g. the corridor still for N frames).
//    Between points the fitted line is extrapolated (a person leaving the view keeps walking).
//    Passes: a point on the other side of the robot's line (y changed sign) than the one before
//    is a pass in the direction it walks; the time from a pass in one direction to the next pass
//    (back, the other way) is remembered for that direction: a person pacing across the way
//    comes back after it. A point back across the line before any was seen pass_fit_m beyond it
//    on the pass's side is the located feet jittering about the line: neither a pass nor a
//    return. Walking away after a pass in a direction whose remembered return leaves less than
//    the time the robot needs -> wait for the next one. With `cautious` (a robot stopped at the edge of
//    the way, CrossingLanes) a direction whose return is not known yet -> wait as well (bounded
//    by the caller).
//  * The time the robot needs (clear_time_s()): with `speed_mps` > 0, from the geometry: the
//    robot, standing `way_ahead_m` before the centre of the person's way, drives until its rear
//    is past the far side of the person's body (way_ahead_m + person_radius_m + body_radius_m +
//    margin_m) at speed_mps, starting from rest with accel_mps2; the policy goes only when the
//    person's arrival in the lane leaves that time plus margin_s. For a person walking away
//    after a pass with a known return: the arrival is return - time since the pass - the lane's
//    half width / its speed (it enters the lane before it reaches the line). Its speed and
//    where it is then come from the pass itself (time of the pass, speed fitted to the points
//    within pass_fit_m of the line): near the robot the person is wider than the view, and
//    the points of a body leaving the view stay at the image's edge, which slows the fitted
//    track (0.6 m/s for a 1 m/s walker 0.9 m ahead). speed_mps = 0
//    (deprecated): the hand-set crossing_s instead, compared with the return itself (the
//    session-12 policy, kept for trees that set only crossing_s).
//  * CrossingLanes: where a person was seen crossing ahead while the robot drove, so that it
//    stops at the edge of that way and watches (the camera sees a person pacing across the path
//    only while it is in front of the robot).
//
// Not thread-safe.
#pragma once

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::ipt {

/// Where the moving thing of a frame difference stands.
struct MovingPoint {
  cv::Point2d ground_m;          ///< robot frame, x ahead, y left
  bool contact_visible = true;   ///< false: the feet are below the image (x is an upper bound)
  int changed_px = 0;
};

/// The moving thing in `changed` (CV_8UC1, non-zero = changed; the camera's size): nullopt when
/// fewer than `min_changed_px` pixels changed or no changed pixel lies below the horizon.
/// Error: wrong image size or type.
[[nodiscard]] Result<std::optional<MovingPoint>> locate_moving(const cv::Mat& changed, const IptCamera& camera,
                                                               int min_changed_px);

struct CrossingParams {
  double lane_half_width_m = 0.6;  ///< the robot's lane: its body radius + a person's + margin, m
  double crossing_s = 3.5;         ///< time the stopped robot needs to clear a lane just ahead, s
  double away_clear_m = 0.3;       ///< a person walking away or standing this far beyond the lane's edge: go, m
  double min_speed_mps = 0.2;      ///< slower counts as standing, m/s
  double window_s = 1.0;           ///< the track's fit window, s
  double forget_s = 2.0;           ///< no point for this long: the track is dropped, s
  int min_points = 3;              ///< points in the window before a decision
  // The clear time from the geometry (speed_mps > 0; 0: crossing_s, deprecated).
  double speed_mps = 0.0;          ///< speed the robot crosses at; 0 = use crossing_s, m/s
  double accel_mps2 = 0.5;         ///< the robot's acceleration from rest, m/s^2
  double body_radius_m = 0.25;     ///< the robot's disc, m
  double person_radius_m = 0.25;   ///< the person's body (a disc), m
  double margin_m = 0.1;           ///< driven beyond the person's far side, m
  double margin_s = 0.5;           ///< time the person's arrival must leave beyond the clear time, s
  double pass_fit_m = 0.3;         ///< a pass's walking speed: fitted to the points this near the robot's line, m
  double approach_m = 1.0;         ///< a way farther ahead is first approached to its edge (the clear time counts from here), m

  [[nodiscard]] Status validate() const;
  static const ParamSchema<CrossingParams>& schema();
};

struct CrossingDecision {
  enum class Kind { no_track, wait, go };
  Kind kind = Kind::no_track;
  double lateral_m = 0.0;            ///< fitted lateral position now (robot frame y)
  double lateral_speed_mps = 0.0;    ///< d|y|/dt: < 0 approaching the lane
  double range_m = 0.0;              ///< fitted x now
  double arrival_s = -1.0;           ///< time until it enters the lane (approaching, or the learnt return), else -1
  double way_ahead_m = 0.0;          ///< distance to the person's way used for the clear time (speed_mps > 0)
  double required_s = 0.0;           ///< the clear time (+ margin_s) the arrival was compared with
  std::string reason;
};

/// Distance the robot drives from `way_ahead_m` before the centre of a person's way until its
/// rear is past the person's far side: max(0, way_ahead_m) + person_radius_m + body_radius_m + margin_m.
[[nodiscard]] double clear_distance_m(const CrossingParams& params, double way_ahead_m);
/// Time to drive clear_distance_m() from rest at params.speed_mps (> 0) with params.accel_mps2:
/// d / v + v / (2 a) when the speed is reached, sqrt(2 d / a) otherwise. Seconds.
[[nodiscard]] double clear_time_s(const CrossingParams& params, double way_ahead_m);

class CrossingPolicy {
 public:
  /// Params must validate().
  explicit CrossingPolicy(CrossingParams params) : params_(params) {}
  /// A point seen at `time_s` (seconds, increasing).
  void observe(double time_s, const MovingPoint& point);
  /// The decision at `time_s` (>= the last observation); `cautious`: see the file comment.
  /// `way_ahead_m`: distance from the robot to the centre of the person's way when known
  /// otherwise (a remembered way); else the track's fitted range, at most approach_m (a go
  /// farther away drives the robot to the way's edge, where it decides again; speed_mps > 0 only).
  [[nodiscard]] CrossingDecision decide(double time_s, bool cautious = false,
                                        std::optional<double> way_ahead_m = std::nullopt) const;
  /// Forgets the track and the passes.
  void reset() {
    forget_track();
    return_after_s_[0] = return_after_s_[1] = -1.0;
  }
  /// Forgets the track and the last pass, keeps the learnt returns (a new stop near the same
  /// person: how long it stays away is a property of its walk, not of the stop).
  void forget_track() {
    track_.clear();
    last_pass_dir_ = 0;
    last_pass_speed_mps_ = -1.0;
    farthest_since_pass_m_ = 0.0;
  }
  /// Walking speed fitted at the last pass, m/s; -1 when none.
  [[nodiscard]] double last_pass_speed_mps() const { return last_pass_speed_mps_; }
  /// Time of the last point, or -1 when none was seen since reset().
  [[nodiscard]] double last_seen_s() const { return last_seen_s_; }
  /// Remembered time from a pass walking to the robot's left (dir +1) or right (-1) to the
  /// person's next pass back; -1 when not seen yet.
  [[nodiscard]] double return_after_s(int dir) const { return return_after_s_[dir > 0 ? 0 : 1]; }
  [[nodiscard]] std::size_t points() const { return track_.size(); }
  [[nodiscard]] const CrossingParams& params() const { return params_; }

 private:
  struct Sample {
    double time_s;
    cv::Point2d ground_m;
  };
  CrossingParams params_;
  std::deque<Sample> track_;
  double last_seen_s_ = -1.0;
  double last_y_ = 0.0;
  int last_pass_dir_ = 0;          // +1 walking left, -1 right, 0 none
  double last_pass_s_ = 0.0;
  double last_pass_speed_mps_ = -1.0;
  double farthest_since_pass_m_ = 0.0;  // largest |y| seen on the pass's side since the last pass
  double return_after_s_[2] = {-1.0, -1.0};  // [0]: after a pass to the left, [1]: to the right
};

/// Where a person was seen crossing ahead of a driving robot, remembered in the odometry frame
/// so that the robot stops at the edge of that person's way (the kerb) instead of driving into
/// it when the person comes back out of the camera's view. [ours] The person's way is taken
/// across the robot's path: a sighting at ground point P (robot frame) marks a crossing at the
/// along-track distance of P.
class CrossingLanes {
 public:
  /// A sighting at `ground_m` (robot frame) with the robot at `robot` (odometry frame) at `time_s`.
  void add(const Pose2D& robot, const cv::Point2d& ground_m, double time_s);
  /// Along-track distance from the robot to the nearest remembered crossing ahead of it (> 0),
  /// nullopt when none. Crossings behind the robot (passed) or older than `forget_s` are dropped.
  [[nodiscard]] std::optional<double> ahead_m(const Pose2D& robot, double time_s, double forget_s);
  void clear() { lanes_.clear(); }
  [[nodiscard]] std::size_t size() const { return lanes_.size(); }

 private:
  struct Lane {
    cv::Point2d at_m;  // odometry frame
    double time_s;
  };
  std::vector<Lane> lanes_;
};

[[nodiscard]] const char* to_string(CrossingDecision::Kind kind);

}  // namespace visnav::ipt
