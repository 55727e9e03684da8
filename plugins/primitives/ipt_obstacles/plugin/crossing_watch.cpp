// The crossing policy's adapter for ReplayAvoiding (see the header).
#include "crossing_watch.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace visnav::ipt {

bt::PortsList crossing_ports() {
  return {bt::input_port<double>("crossing_speed_mps", "0",
                                 "moving obstacles: > 0 turns the crossing policy on: the robot crosses a person's way "
                                 "at this speed, holding its heading, and goes only when the person's arrival in its "
                                 "lane leaves the time it needs (from the geometry) + crossing_margin_s; 0 = off (or "
                                 "crossing_s)"),
          bt::input_port<double>("crossing_margin_s", "0.5",
                                 "crossing policy: time the person's arrival must leave beyond the robot's clear time, s"),
          bt::input_port<double>("crossing_s", "0",
                                 "deprecated (use crossing_speed_mps): > 0 turns the crossing policy on with this "
                                 "hand-set time to clear a person's lane, the replay child crossing at its own speed; "
                                 "0 = off"),
          bt::input_port<double>("crossing_lane_m", "0.6",
                                 "crossing policy: half width of the robot's lane (body + a person + margin), m"),
          bt::input_port<double>("crossing_clear_m", "0.3",
                                 "crossing policy: a person walking away (or standing) this far beyond the lane's edge "
                                 "lets the robot go, m"),
          bt::input_port<double>("crossing_band_m", "4",
                                 "crossing policy: half width of the band watched for the person (frame difference "
                                 "0.3-8 m ahead), m"),
          bt::with_range(bt::input_port<double>("crossing_kerb_m", "0.7",
                                 "crossing policy: a person seen crossing ahead while driving stops the robot when its "
                                 "way is this far ahead of the robot centre, to watch it pass, m"), 0.0, 5.0),
          bt::with_range(bt::input_port<double>("crossing_wait_s", "15",
                                 "crossing policy: at such a stop, seconds of waiting for the person to pass before the "
                                 "robot goes on"), 0.0, 600.0)};
}

Result<std::optional<CrossingWatch>> CrossingWatch::from_ports(const bt::TreeNode& node, const IptCamera& camera) {
  VISNAV_ASSIGN(const double crossing_s, node.get_input<double>("crossing_s"));
  VISNAV_ASSIGN(const double speed_mps, node.get_input<double>("crossing_speed_mps"));
  if (crossing_s == 0.0 && speed_mps == 0.0) return std::optional<CrossingWatch>{};
  if (crossing_s != 0.0 && speed_mps != 0.0)
    return Error{"ports 'crossing_s' and 'crossing_speed_mps': set one (crossing_s is the deprecated hand-set clear time)",
                 ErrorCode::inconsistent};
  VISNAV_ASSIGN(const double kerb_m, node.get_input<double>("crossing_kerb_m"));
  VISNAV_ASSIGN(const double wait_s, node.get_input<double>("crossing_wait_s"));
  if (!(kerb_m >= 0.0 && kerb_m <= 5.0)) return Error{"port 'crossing_kerb_m': must lie in [0, 5] m", ErrorCode::out_of_range};
  if (!(wait_s >= 0.0 && wait_s <= 600.0)) return Error{"port 'crossing_wait_s': must lie in [0, 600] s", ErrorCode::out_of_range};
  CrossingParams params;
  if (crossing_s != 0.0) params.crossing_s = crossing_s;
  params.speed_mps = speed_mps;
  VISNAV_ASSIGN(params.margin_s, node.get_input<double>("crossing_margin_s"));
  VISNAV_ASSIGN(params.body_radius_m, node.get_input<double>("body_radius_m"));
  VISNAV_ASSIGN(params.lane_half_width_m, node.get_input<double>("crossing_lane_m"));
  VISNAV_ASSIGN(params.away_clear_m, node.get_input<double>("crossing_clear_m"));
  if (auto st = params.validate(); !st)
    return Error{"ports 'crossing_s', 'crossing_speed_mps', 'crossing_margin_s', 'body_radius_m', 'crossing_lane_m', "
                 "'crossing_clear_m': " + st.error().message,
                 ErrorCode::out_of_range};
  MotionWatchParams band;
  VISNAV_ASSIGN(band.half_width_m, node.get_input<double>("crossing_band_m"));
  VISNAV_ASSIGN(band.diff_threshold, node.get_input<double>("motion_threshold"));
  VISNAV_ASSIGN(band.min_changed_px, node.get_input<int>("motion_min_px"));
  band.near_m = 0.3;
  band.far_m = 8.0;
  auto watch = MotionWatch::create(camera, band);
  if (!watch) return Error{"port 'crossing_band_m': " + watch.error().message, ErrorCode::out_of_range};
  // While driving: the ground-compensated difference 0.8-5 m ahead (nearer, a millimetre of
  // odometry is a pixel), as wide as the band up to 2.5 m.
  MotionWatchParams driving = band;
  driving.near_m = 0.8;
  driving.far_m = 5.0;
  driving.half_width_m = std::min(band.half_width_m, 2.5);
  driving.min_changed_px = 4 * band.min_changed_px;
  auto drive_watch = MotionWatch::create(camera, driving);
  if (!drive_watch) return Error{"port 'crossing_band_m': " + drive_watch.error().message, ErrorCode::out_of_range};
  // The node crosses from a go within crossing_kerb_m + 0.3 m of the way; farther, it drives
  // up to the way's edge first (ReplayAvoiding::look_step).
  params.approach_m = kerb_m + 0.3;
  CrossingWatch made(std::move(*watch), std::move(*drive_watch), CrossingPolicy(params), band.min_changed_px);
  made.camera_ = camera;
  made.kerb_m_ = kerb_m;
  made.kerb_wait_s_ = wait_s;
  made.drive_near_m_ = driving.near_m;
  return std::optional<CrossingWatch>{std::move(made)};
}

Result<CrossingDecision> CrossingWatch::observe(const cv::Mat& grey, double time_s, bool cautious) {
  VISNAV_ASSIGN(const auto changed, watch_.observe(grey));
  if (changed && watch_.moving()) {
    VISNAV_ASSIGN(const auto point, locate_moving(watch_.last_changed(), camera_, min_px_));
    if (point) policy_.observe(time_s, *point);
  }
  return policy_.decide(time_s, cautious);
}

Result<bool> CrossingWatch::drive(const cv::Mat& grey, const Pose2D& motion, const Pose2D& robot, double time_s) {
  VISNAV_ASSIGN(const auto changed, drive_watch_.observe(grey, motion));
  if (changed) {
    // As ReplayAvoiding's near-corridor trigger: a count well above the recent shimmer level.
    const bool cruising = std::abs(motion.x_m) >= 0.02;
    if (drive_shimmer_.update(*changed, cruising, drive_watch_.moving())) {
      VISNAV_ASSIGN(const auto point, locate_moving(drive_watch_.last_changed(), camera_, min_px_));
      // Only feet in view, beyond the band's near rows (where the odometry's error changes most
      // pixels): a person's way seen ahead, not the robot's own parallax.
      if (point && point->contact_visible && point->ground_m.x >= drive_near_m_ + 0.3) lanes_.add(robot, point->ground_m, time_s);
    }
  }
  const auto ahead = lanes_.ahead_m(robot, time_s, 30.0);
  return ahead && *ahead <= kerb_m_;
}

}  // namespace visnav::ipt
