#include "odometry_tracker.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::robot_dds {

namespace {
bool finite(double v) { return std::isfinite(v); }
}  // namespace

Result<Odometry> OdometryTracker::update(const dds::msg::Odometry& sample, double timestamp_s) {
  const auto& p = sample.pose.pose.position;
  const auto& q = sample.pose.pose.orientation;
  const auto& v = sample.twist.twist;
  if (!finite(p.x) || !finite(p.y) || !finite(p.z)) return fail("odometry position is not finite");
  if (!finite(q.x) || !finite(q.y) || !finite(q.z) || !finite(q.w)) return fail("odometry orientation is not finite");
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (norm < 1e-6) return fail("odometry orientation is a zero quaternion");
  if (!finite(v.linear.x) || !finite(v.angular.z)) return fail("odometry twist is not finite");

  Odometry out;
  out.timestamp_s = timestamp_s;
  out.pose.x_m = p.x;
  out.pose.y_m = p.y;
  out.pose.heading_rad = dds::yaw_from_quaternion(dds::msg::Quaternion{q.x / norm, q.y / norm, q.z / norm, q.w / norm});
  out.twist.linear_mps = v.linear.x;
  out.twist.angular_radps = v.angular.z;
  if (previous_) {
    const double dx = out.pose.x_m - previous_->x_m;
    const double dy = out.pose.y_m - previous_->y_m;
    const double mean_heading =
        previous_->heading_rad + 0.5 * std::remainder(out.pose.heading_rad - previous_->heading_rad, 2.0 * M_PI);
    distance_m_ += dx * std::cos(mean_heading) + dy * std::sin(mean_heading);
  }
  previous_ = out.pose;
  out.distance_m = distance_m_;
  return out;
}

dds::msg::Twist to_ros_twist(const Twist& command) {
  dds::msg::Twist t;
  t.linear.x = command.linear_mps;
  t.angular.z = command.angular_radps;
  return t;
}

double to_run_clock(double stamp_epoch_s, double epoch_now_s, double run_now_s) {
  return run_now_s - std::max(0.0, epoch_now_s - stamp_epoch_s);
}

}  // namespace visnav::robot_dds
