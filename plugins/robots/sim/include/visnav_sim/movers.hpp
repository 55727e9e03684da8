// visnav simulator — where the moving obstacles are when some of them yield to the robot
// (issue 16: a person who stops in front of a standing or passing robot).
//
// A blind walker's position is a pure function of time (MovingObstacle::position_at). A
// yielding one (MovingObstacle::yield_m > 0) stands while the robot's body is within yield_m
// ahead of it on its way, so where it is depends on where the robot was: MoverStates integrates
// the metres each yielding walker has walked, step by step with the robot's simulation, and
// keeps a history of (time, walked metres) so that a camera rendering a frame of an earlier
// capture time (latency) shows the walker where it was then. The robot (collision check) and the
// camera (renderer) of one run read the same MoverStates through RobotCore::mover_offset(), so a
// render and a collision agree; the integration depends only on the robot's simulated poses,
// so the same seed gives the same run.
//
// The yield test at time t, walker at p walking in unit direction d, robot centre c:
//   along = (c - p)·d,  lateral = |(c - p) × d|;
//   it stands when along > 0, along - radius - body_radius ≤ yield_m and
//   lateral < radius + body_radius + kSideMargin_m (the robot's disc is on its way).
// Not thread-safe: RobotCore guards it with its mutex.
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav_sim/world.hpp"

namespace visnav::sim {

class MoverStates {
 public:
  /// Side clearance a yielding walker keeps beyond touching, m.
  static constexpr double kSideMargin_m = 0.1;

  /// Starts over for `world` (may be null) at simulated time `time_s`: every walker where its
  /// blind motion puts it then.
  void reset(const World* world, double time_s);
  /// Advances the yielding walkers from `time_s` to `time_s + dt_s` with the robot's body (centre
  /// `robot`, radius `body_radius_m`) at the start of the step; keeps `history_s` of history.
  void advance(double time_s, double dt_s, const cv::Point2d& robot, double body_radius_m, double history_s);
  /// Displacement of mover `mover` (World::movers index) at time `time_s`: the blind motion for a
  /// blind walker; the walked metres of the history (linear between entries, clamped to its
  /// ends) for a yielding one.
  [[nodiscard]] cv::Point2d offset_at(int mover, double time_s) const;
  /// True when the yielding walker `mover` stood during the last advance().
  [[nodiscard]] bool standing(int mover) const;
  /// The world this state belongs to.
  [[nodiscard]] const World* world() const { return world_; }

  /// The yield test above (pure; exposed for tests).
  [[nodiscard]] static bool yields(const MovingObstacle& m, const cv::Point2d& position, const cv::Point2d& direction,
                                   const cv::Point2d& robot, double body_radius_m);

 private:
  struct Walker {
    double walked_m = 0.0;
    bool standing = false;
    std::deque<std::pair<double, double>> history;  // (time, walked_m)
  };
  const World* world_ = nullptr;
  std::vector<Walker> walkers_;  // one per World::movers entry (used for yielding ones)
};

}  // namespace visnav::sim
