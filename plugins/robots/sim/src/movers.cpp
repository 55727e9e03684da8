// visnav simulator — yielding walkers (see movers.hpp).
#include "visnav_sim/movers.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::sim {

void MoverStates::reset(const World* world, double time_s) {
  world_ = world;
  walkers_.clear();
  if (world_ == nullptr) return;
  walkers_.resize(world_->movers.size());
  for (std::size_t i = 0; i < walkers_.size(); ++i) {
    walkers_[i].walked_m = world_->movers[i].walked_at(time_s);
    walkers_[i].history.emplace_back(time_s, walkers_[i].walked_m);
  }
}

bool MoverStates::yields(const MovingObstacle& m, const cv::Point2d& position, const cv::Point2d& direction,
                         const cv::Point2d& robot, double body_radius_m) {
  if (m.yield_m <= 0.0 || cv::norm(direction) < 0.5) return false;
  const cv::Point2d r = robot - position;
  const double along = r.dot(direction);
  const double lateral = std::abs(r.x * direction.y - r.y * direction.x);
  return along > 0.0 && along - m.radius_m - body_radius_m <= m.yield_m &&
         lateral < m.radius_m + body_radius_m + kSideMargin_m;
}

void MoverStates::advance(double time_s, double dt_s, const cv::Point2d& robot, double body_radius_m, double history_s) {
  if (world_ == nullptr) return;
  const double t1 = time_s + dt_s;
  for (std::size_t i = 0; i < walkers_.size(); ++i) {
    const MovingObstacle& m = world_->movers[i];
    if (m.yield_m <= 0.0) continue;
    Walker& w = walkers_[i];
    // Walking time inside this step: none before start_s.
    const double walking_s = std::max(0.0, t1 - std::max(time_s, m.start_s));
    if (walking_s > 0.0) {
      cv::Point2d direction;
      const cv::Point2d p = m.position_walked(w.walked_m, &direction);
      w.standing = yields(m, p, direction, robot, body_radius_m);
      if (!w.standing) w.walked_m += m.speed_mps * walking_s;
    }
    w.history.emplace_back(t1, w.walked_m);
    while (w.history.size() > 2 && w.history[1].first < t1 - history_s) w.history.pop_front();
  }
}

cv::Point2d MoverStates::offset_at(int mover, double time_s) const {
  const MovingObstacle& m = world_->movers[static_cast<std::size_t>(mover)];
  if (m.yield_m <= 0.0) return m.offset_at(time_s);
  const auto& h = walkers_[static_cast<std::size_t>(mover)].history;
  double walked = 0.0;
  if (time_s >= h.back().first) {
    walked = h.back().second;
  } else if (time_s <= h.front().first) {
    walked = h.front().second;
  } else {
    auto it = std::lower_bound(h.begin(), h.end(), time_s, [](const auto& e, double v) { return e.first < v; });
    const auto& b = *it;
    const auto& a = *(it - 1);
    const double k = (time_s - a.first) / std::max(1e-12, b.first - a.first);
    walked = a.second + k * (b.second - a.second);
  }
  return m.position_walked(walked) - m.path.front();
}

bool MoverStates::standing(int mover) const {
  return mover >= 0 && static_cast<std::size_t>(mover) < walkers_.size() && walkers_[static_cast<std::size_t>(mover)].standing;
}

}  // namespace visnav::sim
