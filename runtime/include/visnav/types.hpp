// visnav SDK — plain value types exchanged between the runtime and plugins.
//
// Frames and units:
//  * `odom` frame: right-handed, x forward at start, y left, z up; metres, radians,
//    heading counter-clockwise from +x. Wheel odometry drifts in this frame.
//  * `world` frame: the simulator's ground-truth frame. Only evaluation code reads it.
//  * Image coordinates: pixels, origin top-left, u to the right, v down.
//  * Time: seconds on the run's clock (`Clock`), which is simulated time in simulation.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>

namespace visnav {

/// Planar pose.
struct Pose2D {
  double x_m = 0.0;
  double y_m = 0.0;
  double heading_rad = 0.0;
};

/// Velocity command / measured velocity of a ground robot.
struct Twist {
  double linear_mps = 0.0;     ///< forward speed, m/s
  double angular_radps = 0.0;  ///< yaw rate, rad/s, counter-clockwise positive
};

/// One odometry reading.
struct Odometry {
  double timestamp_s = 0.0;
  Pose2D pose;                ///< in the odom frame
  double distance_m = 0.0;    ///< signed path length travelled since start (forward positive)
  Twist twist;                ///< measured velocity
};

/// One camera frame. `image` is 8-bit BGR (CV_8UC3) or grey (CV_8UC1).
/// Ownership: cv::Mat is reference counted; producers must not write into a Mat
/// after handing it over (hand over a fresh buffer or a clone).
struct Frame {
  double timestamp_s = 0.0;
  std::uint64_t sequence = 0;
  cv::Mat image;
};

}  // namespace visnav
