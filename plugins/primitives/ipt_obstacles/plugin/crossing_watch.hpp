// visnav IPT obstacles — the crossing policy's adapter for ReplayAvoiding's stop-and-look
// (issue 16, docs/obstacles.md "Crossing policy"): a frame difference over a band wider than the
// corridor (MotionWatch, ± the crossing's band_m), the moving thing's ground point (locate_moving) and
// the CrossingPolicy's decision, from the node's `crossing` and `look` params. Thin: the logic is in
// crossing_policy.hpp.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "avoiding_params.hpp"
#include "visnav/ipt_obstacles/crossing_policy.hpp"
#include "visnav/ipt_obstacles/motion_watch.hpp"

namespace visnav::ipt {

class CrossingWatch {
 public:
  /// nullopt when crossing.speed_mps is 0 (off). The band's frame difference takes the look's
  /// motion_threshold and motion_min_px. Error: a bad value (naming the port and key).
  static Result<std::optional<CrossingWatch>> create(const CrossingPortParams& crossing, const LookParams& look,
                                                     double body_radius_m, const IptCamera& camera);
  /// One frame of the standing camera at `time_s`: the decision after it (`cautious`: stopped
  /// at the edge of a person's way, CrossingPolicy::decide()).
  Result<CrossingDecision> observe(const cv::Mat& grey, double time_s, bool cautious);
  /// The speed the robot crosses a person's way at (crossing speed_mps, > 0).
  [[nodiscard]] double crossing_speed_mps() const { return policy_.params().speed_mps; }
  /// Distance to drive from `way_ahead_m` before the way until the robot's body is past the person's.
  [[nodiscard]] double clear_distance_m(double way_ahead_m) const {
    return ipt::clear_distance_m(policy_.params(), way_ahead_m);
  }
  /// Seconds since the policy last located the person (a large value when never).
  [[nodiscard]] double unseen_s(double time_s) const {
    return policy_.last_seen_s() < 0.0 ? 1e9 : time_s - policy_.last_seen_s();
  }
  /// Remembers the person's way `ahead_m` ahead of the robot at `robot` (odometry frame): the
  /// robot stops before it (a stop too far from the way to cross in time).
  void remember_way(const Pose2D& robot, double ahead_m, double time_s) { lanes_.add(robot, {ahead_m, 0.0}, time_s); }
  [[nodiscard]] double kerb_m() const { return kerb_m_; }
  /// True when a person's way is remembered within `within_m` ahead: an IPT contact there is
  /// likely that person (the robot waits at the way instead of detouring into it).
  [[nodiscard]] bool way_ahead(const Pose2D& robot, double time_s, double within_m) {
    const auto ahead = lanes_.ahead_m(robot, time_s, 30.0);
    return ahead && *ahead <= within_m;
  }
  /// The camera moved: the next frame starts a new difference (the track is kept).
  void restart_difference() { watch_.reset(); }
  /// Forgets the track too (a new stop); the remembered crossings and the person's learnt
  /// returns are kept (CrossingPolicy::forget_track()).
  void reset() {
    watch_.reset();
    policy_.forget_track();
    drive_watch_.reset();
    drive_shimmer_.reset_hits();
  }
  /// One frame while driving: `motion` is the robot's motion since the previous frame (its
  /// frame then), `robot` its odometry pose now. A person crossing ahead (the ground-compensated
  /// difference over the driving band well above the recent level on two frames in a row) is
  /// remembered; true when a remembered crossing is the crossing's kerb_m ahead or nearer: stop there.
  Result<bool> drive(const cv::Mat& grey, const Pose2D& motion, const Pose2D& robot, double time_s);
  /// Seconds a robot stopped at a kerb waits for the person to pass (the crossing's wait_s).
  [[nodiscard]] double kerb_wait_s() const { return kerb_wait_s_; }
  /// Forgets the person's learnt returns as well (the edge is done).
  void forget_person() {
    reset();
    policy_.reset();
  }
  /// Forgets the remembered crossings (the robot crossed, or gave up waiting).
  void clear_lanes() { lanes_.clear(); }

 private:
  CrossingWatch(MotionWatch watch, MotionWatch drive_watch, CrossingPolicy policy, int min_px)
      : watch_(std::move(watch)), drive_watch_(std::move(drive_watch)), policy_(policy), min_px_(min_px) {}
  MotionWatch watch_;
  MotionWatch drive_watch_;
  CrossingPolicy policy_;
  CrossingLanes lanes_;
  int min_px_ = 80;
  IptCamera camera_;
  double kerb_m_ = 0.7;
  double kerb_wait_s_ = 15.0;
  double drive_near_m_ = 0.8;
  ShimmerTrigger drive_shimmer_;
};

}  // namespace visnav::ipt
