#include "run/odometry_check.hpp"

#include <cmath>
#include <cstdio>

namespace visnav {

namespace {

std::string fmt(double v, const char* format = "%.3f") {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

bool finite(const Odometry& o) {
  return std::isfinite(o.timestamp_s) && std::isfinite(o.pose.x_m) && std::isfinite(o.pose.y_m) &&
         std::isfinite(o.pose.heading_rad) && std::isfinite(o.distance_m) && std::isfinite(o.twist.linear_mps) &&
         std::isfinite(o.twist.angular_radps);
}

bool same(const Odometry& a, const Odometry& b) {
  return a.pose.x_m == b.pose.x_m && a.pose.y_m == b.pose.y_m && a.pose.heading_rad == b.pose.heading_rad &&
         a.distance_m == b.distance_m;
}

}  // namespace

std::optional<std::string> OdometryPlausibility::check(const Odometry& reading) {
  last_late_ = false;
  if (!finite(reading)) {
    return "odometry reading with a non-finite value (t " + fmt(reading.timestamp_s) + " s, x " + fmt(reading.pose.x_m) +
           ", y " + fmt(reading.pose.y_m) + ", heading " + fmt(reading.pose.heading_rad) + ", distance " +
           fmt(reading.distance_m) + ")";
  }
  if (!last_) {
    last_ = reading;
    return std::nullopt;
  }
  const Odometry& prev = *last_;
  const double dt_s = reading.timestamp_s - prev.timestamp_s;
  if (dt_s < 0.0) {
    last_late_ = true;
    return "odometry time went backwards from " + fmt(prev.timestamp_s, "%.6f") + " s to " +
           fmt(reading.timestamp_s, "%.6f") + " s";
  }
  if (dt_s == 0.0) {
    if (same(prev, reading)) return std::nullopt;  // the robot reported its latest reading again
    return "two different odometry readings with the same timestamp " + fmt(reading.timestamp_s, "%.6f") + " s";
  }
  // Time is at worst a little late (latency), never far: bound the move by the real interval.
  const double allowed_m = limits_.max_speed_mps * dt_s + limits_.slack_m;
  const double moved_m = std::hypot(reading.pose.x_m - prev.pose.x_m, reading.pose.y_m - prev.pose.y_m);
  const double travelled_m = std::fabs(reading.distance_m - prev.distance_m);
  const double worst_m = std::max(moved_m, travelled_m);
  if (worst_m > allowed_m) {
    return "odometry jumped " + fmt(worst_m, "%.2f") + " m in " + fmt(dt_s) + " s (" +
           (moved_m >= travelled_m ? "position" : "distance_m") + "; at most " + fmt(allowed_m, "%.2f") +
           " m at odometry_max_speed_mps = " + fmt(limits_.max_speed_mps, "%.2f") + " + odometry_jump_slack_m = " +
           fmt(limits_.slack_m, "%.2f") + ")";
  }
  last_ = reading;
  return std::nullopt;
}

}  // namespace visnav
