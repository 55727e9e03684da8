// visnav IPT obstacles — back off and look: the width of something standing close ahead that
// the IPT did not find ([ours]; issue 16, docs/obstacles.md "A van the path follower keeps the
// path up to").
//
// While a replay drives, the ground-compensated frame difference (motion_watch.hpp) stops the
// robot when something changes close ahead (a person stepping in, or the parallax of a face
// standing 0.6-2 m ahead). When the stopped robot then sees nothing move and the IPT has no
// ground contact in the corridor (a plain, path-coloured face: the campus's concrete van), the
// obstacle is close and only a part of it is in view (at 0.6 m a 60° camera sees 0.7 m of it):
// too close and too little to drive around. BackOffLook reverses slowly on the heading the robot
// stopped with for `distance_m` of odometry while the node feeds it the corners the
// longer-baseline triangulation (near_triangulation.hpp) places above the ground: reversing
// widens the view, so the later triangulations cover the face's whole width, and the robot ends
// far enough away for a lane detour. At the end the verdict counts the points in the corridor
// ahead (something stands there: detour with every point, so the lane detour chooses its side
// with the face's full width) and reports the face's distance (median of the corridor points)
// and the lateral extent of the points ahead. From 0.6 m before a face, 2 m of reversing puts it
// 2.6 m ahead, where a 60° camera sees 1.5 m to either side: a van's rear 0.4 m off the heading
// fits (at 2.1 m, after 1.5 m, its far edge was out of view: test BackOffLook.*).
// Frames: odom (x, y, heading), metres, radians. Pure; not thread-safe.
#pragma once

#include <span>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct BackOffLookParams {
  double distance_m = 2.0;              ///< reverse travel (odometry)
  double speed_mps = 0.15;              ///< reverse speed (commanded as −speed_mps)
  double heading_gain_per_s = 1.5;      ///< omega = gain * (held heading − heading)
  double max_angular_radps = 0.4;       ///< turn-rate limit
  int min_points = 4;                   ///< points in the corridor ahead that make it an obstacle
  double corridor_half_width_m = 0.45;  ///< the corridor's half width about the held heading line
  double reach_m = 4.0;                 ///< points at most this far ahead of the final pose count
  double face_depth_m = 0.6;            ///< the lateral extent counts points within this of the face's distance
                                        ///< (found only; campus seed 3: a corner 1 m beside a van at another
                                        ///< depth chose the side); 0 = every point ahead

  [[nodiscard]] Status validate() const;
  static const ParamSchema<BackOffLookParams>& schema();
};

struct BackOffVerdict {
  bool found = false;      ///< at least min_points in the corridor ahead
  int in_corridor = 0;     ///< points in the corridor ahead
  int ahead = 0;           ///< points ahead within reach_m (any lateral offset within 3 m)
  double range_m = 0.0;    ///< median along-heading distance of the corridor points (found only)
  double left_m = 0.0;     ///< largest lateral offset (left +) of the points ahead (ahead > 0); found and
                           ///< face_depth_m > 0: of the points within face_depth_m of range_m
  double right_m = 0.0;    ///< smallest lateral offset of the same points
};

class BackOffLook {
 public:
  struct Step {
    Twist command;      ///< to send while backing off
    bool done = false;  ///< the travel is complete: stop and take the verdict
  };
  /// Params must validate().
  explicit BackOffLook(BackOffLookParams params) : params_(params) {}
  /// Starts backing off from `pose` (odometer reading `odometer_m`, signed: it falls while
  /// reversing); forgets earlier points.
  void begin(const Pose2D& pose, double odometer_m);
  /// Obstacle points (odom frame) triangulated while backing off.
  void add_points(std::span<const cv::Point2d> points_m);
  /// One cycle: reverse holding the start heading, or done once `distance_m` is covered.
  [[nodiscard]] Step step(const Pose2D& pose, double odometer_m) const;
  /// The points relative to `pose`'s position and the held heading.
  [[nodiscard]] BackOffVerdict verdict(const Pose2D& pose) const;
  [[nodiscard]] const std::vector<cv::Point2d>& points() const { return points_; }
  [[nodiscard]] const BackOffLookParams& params() const { return params_; }

 private:
  BackOffLookParams params_;
  double start_odometer_m_ = 0.0;
  double heading_rad_ = 0.0;
  std::vector<cv::Point2d> points_;
};

}  // namespace visnav::ipt
