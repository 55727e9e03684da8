// The crossing policy's adapter for ReplayAvoiding (see the header).
#include "crossing_watch.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace visnav::ipt {

Result<std::optional<CrossingWatch>> CrossingWatch::create(const CrossingPortParams& crossing, const LookParams& look,
                                                           double body_radius_m, const IptCamera& camera) {
  if (crossing.speed_mps == 0.0) return std::optional<CrossingWatch>{};
  if (auto st = crossing.validate(); !st) return st.error().with_context("port 'crossing'");
  const double kerb_m = crossing.kerb_m, wait_s = crossing.wait_s;
  CrossingParams params;
  params.speed_mps = crossing.speed_mps;
  params.margin_s = crossing.margin_s;
  params.body_radius_m = body_radius_m;
  params.lane_half_width_m = crossing.lane_m;
  params.away_clear_m = crossing.clear_m;
  if (auto st = params.validate(); !st)
    return Error{"ports 'crossing', 'body_radius_m': " + st.error().message, ErrorCode::out_of_range};
  MotionWatchParams band;
  band.half_width_m = crossing.band_m;
  band.diff_threshold = look.motion_threshold;
  band.min_changed_px = look.motion_min_px;
  band.near_m = 0.3;
  band.far_m = 8.0;
  auto watch = MotionWatch::create(camera, band);
  if (!watch) return Error{"port 'crossing', key 'band_m': " + watch.error().message, ErrorCode::out_of_range};
  // While driving: the ground-compensated difference 0.8-5 m ahead (nearer, a millimetre of
  // odometry is a pixel), as wide as the band up to 2.5 m.
  MotionWatchParams driving = band;
  driving.near_m = 0.8;
  driving.far_m = 5.0;
  driving.half_width_m = std::min(band.half_width_m, 2.5);
  driving.min_changed_px = 4 * band.min_changed_px;
  auto drive_watch = MotionWatch::create(camera, driving);
  if (!drive_watch) return Error{"port 'crossing', key 'band_m': " + drive_watch.error().message, ErrorCode::out_of_range};
  // The node crosses from a go within kerb_m + 0.3 m of the way; farther, it drives
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
