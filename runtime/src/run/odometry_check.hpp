// Odometry plausibility (issue 17): a reading that no robot could have produced — non-finite
// values, time running backwards, or a jump farther than max_speed_mps allows in the time since
// the previous reading — is refused, and the run loop stops the robot with the reason.
// Spoofed or corrupt odometry would otherwise end edges early or drive the next edge from the
// wrong place.
#pragma once

#include <optional>
#include <string>

#include "visnav/types.hpp"

namespace visnav {

/// Limits of the check; both from the `run:` block (odometry_max_speed_mps, odometry_jump_slack_m).
struct OdometryLimits {
  double max_speed_mps = 3.0;  ///< fastest the robot can move (pose and distance_m), > 0
  double slack_m = 0.5;        ///< allowed on top of max_speed_mps x dt (noise, latency), >= 0
};

/// Checks a stream of readings in arrival order. Pure (no clock, no I/O); one thread.
class OdometryPlausibility {
 public:
  explicit OdometryPlausibility(OdometryLimits limits) : limits_(limits) {}
  /// nullopt if `reading` is plausible after the previously accepted one (and then remembers
  /// it); otherwise a one-line reason naming the values, e.g. "odometry jumped 30.00 m in
  /// 1.000 s (max 3.50 m at odometry_max_speed_mps = 3.0)". The same reading repeated (equal
  /// timestamp and values) is plausible.
  [[nodiscard]] std::optional<std::string> check(const Odometry& reading);
  /// True if the last refused reading was only older than the previous one (time went
  /// backwards): a late, reordered sample, which the caller may drop instead of stopping.
  [[nodiscard]] bool last_was_late() const { return last_late_; }

 private:
  OdometryLimits limits_;
  std::optional<Odometry> last_;
  bool last_late_ = false;
};

}  // namespace visnav
