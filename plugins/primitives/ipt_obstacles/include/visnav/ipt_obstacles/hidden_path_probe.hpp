// visnav IPT obstacles — the probe ahead when a replay's path follower loses the path ([ours];
// issue 16, docs/obstacles.md "A van hiding the path").
//
// A path follower segments the path by colour. An obstacle standing on the path whose colour is
// close to the path's (a concrete-grey van on gravel) makes the segmented region flood the
// image ("path fills image") 2-3 m before the obstacle, farther than the IPT finds the
// obstacle's ground contacts (1.3-2 m for a van's rear); the follower then gives up ("path
// lost") before the avoiding node has seen anything. The probe lets the avoiding node look
// first: it drives slowly straight on, holding the heading the robot had when the child gave up,
// for at most `distance_m` of odometry, while the node's obstacle detectors (IPT corridor, frame
// difference) watch. Something found: the node's stop-and-look and detour take over. Nothing
// found within the budget: the probe is exhausted and the node stops with the child's reason
// (a lost robot stops, issue 12).
//
// The budget is per place: a probe started before the previous one's budget ran out (odometer
// reading) continues that budget instead of starting a new one, so a child failing again right
// after a resume cannot make the robot creep on without end. reset() gives a new budget (after a
// detour passed the obstacle, or when the edge completes).
// Frames: odom, metres, radians. Pure; not thread-safe.
#pragma once

#include <optional>
#include <string>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct HiddenPathProbeParams {
  double distance_m = 1.5;          ///< odometry budget of one probe (per place, see above)
  double speed_mps = 0.15;          ///< forward speed while probing
  double heading_gain_per_s = 1.5;  ///< omega = gain * (held heading - heading)
  double max_angular_radps = 0.4;   ///< turn-rate limit

  [[nodiscard]] Status validate() const;
  static const ParamSchema<HiddenPathProbeParams>& schema();
};

class HiddenPathProbe {
 public:
  struct Step {
    Twist command;           ///< to send while probing
    bool exhausted = false;  ///< the budget is used up: stop (command zero)
  };

  /// Params must validate().
  explicit HiddenPathProbe(HiddenPathProbeParams params) : params_(params) {}

  /// Starts (or continues, see above) a probe at `pose` with odometer reading `odometer_m`.
  void begin(const Pose2D& pose, double odometer_m);
  /// One cycle: the command holding the start heading, or exhausted once the odometer has
  /// reached the budget's end.
  [[nodiscard]] Step step(const Pose2D& pose, double odometer_m) const;
  /// Odometry left in the current budget (0 when exhausted or none started).
  [[nodiscard]] double left_m(double odometer_m) const;
  /// A new budget for the next probe.
  void reset() { end_odometer_m_.reset(); }

 private:
  HiddenPathProbeParams params_;
  std::optional<double> end_odometer_m_;
  double heading_rad_ = 0.0;
};

}  // namespace visnav::ipt
