// robot_dds core: turns nav_msgs/Odometry samples into visnav::Odometry.
//
// ROS odometry has no path length, so the tracker integrates it: each new pose adds the
// displacement projected on the mean heading of the step (forward positive, reversing
// subtracts). Samples with non-finite values or a degenerate quaternion are rejected.
// Thread-safety: not thread-safe; one instance per odometry stream, fed from one thread.
#pragma once

#include <optional>
#include <string>

#include "visnav/dds.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::robot_dds {

class OdometryTracker {
 public:
  /// Converts `sample`, stamped `timestamp_s` (run clock), and advances the path length.
  /// Errors describe the malformed field; the tracker state is unchanged then.
  [[nodiscard]] Result<Odometry> update(const dds::msg::Odometry& sample, double timestamp_s);
  void reset() { previous_.reset(); distance_m_ = 0.0; }
  [[nodiscard]] double distance_m() const { return distance_m_; }

 private:
  std::optional<Pose2D> previous_;
  double distance_m_ = 0.0;
};

/// geometry_msgs/Twist for a visnav command (linear.x, angular.z; everything else zero).
[[nodiscard]] dds::msg::Twist to_ros_twist(const Twist& command);

/// Maps a DDS sample time to the run clock: `run_now_s - max(0, epoch_now_s - stamp_epoch_s)`,
/// i.e. the run-clock time the sample was stamped at, assuming synchronised wall clocks.
/// Never returns a time later than `run_now_s`.
[[nodiscard]] double to_run_clock(double stamp_epoch_s, double epoch_now_s, double run_now_s);

}  // namespace visnav::robot_dds
