#include "visnav/ipt_obstacles/hidden_path_probe.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace visnav::ipt {

Status HiddenPathProbeParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<HiddenPathProbeParams>& HiddenPathProbeParams::schema() {
  using P = HiddenPathProbeParams;
  static const auto s = ParamSchema<P>{}
                            .field("distance_m", &P::distance_m, "odometry budget of one probe, m")
                            .range(0.01, 20.0)
                            .field("speed_mps", &P::speed_mps, "forward speed while probing")
                            .range(0.01, 2.0)
                            .field("heading_gain_per_s", &P::heading_gain_per_s, "heading hold gain")
                            .range(0.0, 20.0)
                            .field("max_angular_radps", &P::max_angular_radps, "turn-rate limit")
                            .range(0.0, 5.0);
  return s;
}

void HiddenPathProbe::begin(const Pose2D& pose, double odometer_m) {
  heading_rad_ = pose.heading_rad;
  if (!end_odometer_m_ || odometer_m >= *end_odometer_m_) end_odometer_m_ = odometer_m + params_.distance_m;
}

HiddenPathProbe::Step HiddenPathProbe::step(const Pose2D& pose, double odometer_m) const {
  Step out;
  if (!end_odometer_m_ || odometer_m >= *end_odometer_m_) {
    out.exhausted = true;
    return out;
  }
  const double error = std::remainder(heading_rad_ - pose.heading_rad, 2.0 * std::numbers::pi);
  out.command.linear_mps = params_.speed_mps;
  out.command.angular_radps =
      std::clamp(params_.heading_gain_per_s * error, -params_.max_angular_radps, params_.max_angular_radps);
  return out;
}

double HiddenPathProbe::left_m(double odometer_m) const {
  return end_odometer_m_ ? std::max(0.0, *end_odometer_m_ - odometer_m) : 0.0;
}

}  // namespace visnav::ipt
