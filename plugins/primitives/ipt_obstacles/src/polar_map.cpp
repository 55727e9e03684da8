#include "visnav/ipt_obstacles/polar_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

namespace visnav::ipt {

namespace {

constexpr double kPi = CV_PI;
constexpr double kDeg = CV_PI / 180.0;

double wrap(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a < 0) a += 2.0 * kPi;
  return a - kPi;
}

struct Polar {
  cv::Point2d p;       // ground frame
  double range_m;
  double bearing_rad;  // robot frame
};

Polar polar_of(const Pose2D& robot, const cv::Point2d& p) {
  const double dx = p.x - robot.x_m, dy = p.y - robot.y_m;
  return {p, std::hypot(dx, dy), wrap(std::atan2(dy, dx) - robot.heading_rad)};
}

bool in_front(double bearing_rad) { return std::fabs(bearing_rad) < kPi / 2; }

struct Candidate {
  double heading_rad;
  Situation situation;
  std::string reason;
};

}  // namespace

const char* to_string(Situation s) {
  switch (s) {
    case Situation::goal_reached: return "goal_reached";
    case Situation::high_risk: return "high_risk";
    case Situation::goal_free: return "goal_free";
    case Situation::goal_grazing: return "goal_grazing";
    case Situation::gap: return "gap";
    case Situation::gap_end_behind: return "gap_end_behind";
    case Situation::no_candidate: return "no_candidate";
    case Situation::blocked: return "blocked";
  }
  return "?";
}

Status PolarMapParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  const double n = 360.0 / sector_width_deg;
  if (std::fabs(n - std::round(n)) > 1e-9)
    return Error{"sector_width_deg must divide 360 (got " + std::to_string(sector_width_deg) + ")",
                 ErrorCode::inconsistent};
  return ok();
}

const ParamSchema<PolarMapParams>& PolarMapParams::schema() {
  using P = PolarMapParams;
  static const auto s =
      ParamSchema<P>{}
          .field("sector_width_deg", &P::sector_width_deg, "polar sector width (thesis 12 deg, 30 sectors)").range(1.0, 90.0)
          .field("security_distance_m", &P::security_distance_m, "S_dist: closer points switch to the potential field")
          .range(0.05, 10.0)
          .field("gap_width_m", &P::gap_width_m, "narrower gaps are forbidden (thesis experiments 0.95 m)").range(0.05, 20.0)
          .field("goal_tolerance_m", &P::goal_tolerance_m, "goal reached within this distance").range(0.01, 10.0)
          .field("step_m", &P::step_m, "travel per cycle, for candidate validation").range(0.0, 5.0)
          .field("repulsion_gain", &P::repulsion_gain, "potential field repulsion gain").range(0.0, 1e6)
          .field("attraction_gain", &P::attraction_gain, "potential field attraction gain").range(0.0, 1e6)
          .field("reset_keep_near_m", &P::reset_keep_near_m, "points this close survive a reset (0 = thesis)")
          .range(0.0, 100.0)
          .field("merge_cell_m", &P::merge_cell_m, "one stored point per square cell of this side (0 = keep every point)")
          .range(0.0, 1.0);
  return s;
}

int NavigationFilter::sector_count() const { return static_cast<int>(std::lround(360.0 / params_.sector_width_deg)); }

int NavigationFilter::sector_of(double bearing_rad) const {
  const int n = sector_count();
  const int k = static_cast<int>(std::floor((wrap(bearing_rad) + kPi) / (params_.sector_width_deg * kDeg)));
  return ((k % n) + n) % n;
}

std::int64_t NavigationFilter::cell_of(const cv::Point2d& p) const {
  const double c = params_.merge_cell_m;
  const auto ix = static_cast<std::int64_t>(std::floor(p.x / c)), iy = static_cast<std::int64_t>(std::floor(p.y / c));
  return (ix << 32) ^ (iy & 0xffffffffLL);
}

void NavigationFilter::add_points(std::span<const cv::Point2d> points_m) {
  if (params_.merge_cell_m <= 0.0) {
    points_.insert(points_.end(), points_m.begin(), points_m.end());
    return;
  }
  // One point per cell, the newest: a robot standing or creeping before an obstacle sees the
  // same contacts every cycle, and the map grew by every sighting (80 000 points after 2 500
  // cycles in a U, each decision sorting them all).
  for (const cv::Point2d& p : points_m) {
    const auto [it, fresh] = cell_index_.try_emplace(cell_of(p), points_.size());
    if (fresh) points_.push_back(p);
    else points_[it->second] = p;
  }
}

void NavigationFilter::reindex() {
  cell_index_.clear();
  if (params_.merge_cell_m <= 0.0) return;
  for (std::size_t i = 0; i < points_.size(); ++i) cell_index_[cell_of(points_[i])] = i;
}

void NavigationFilter::reset(const Pose2D& robot) {
  const double keep = params_.reset_keep_near_m;
  std::erase_if(points_, [&](const cv::Point2d& p) { return std::hypot(p.x - robot.x_m, p.y - robot.y_m) > keep; });
  reindex();
  tenacity_on_ = false;
  rotate_side_ = 0;
}

void NavigationFilter::reset() {
  points_.clear();
  cell_index_.clear();
  tenacity_on_ = false;
  rotate_side_ = 0;
}

namespace {

// The steps of NavigationFilter::decide(); `pts` are the stored points nearer than the goal,
// `nearest` each sector's nearest of them (index into pts, −1 for an empty sector).

/// The filter: only points between the robot and the goal (R_nf = |goal − robot|).
std::vector<Polar> points_nearer_than_goal(const std::vector<cv::Point2d>& points, const Pose2D& robot, double goal_range_m) {
  std::vector<Polar> pts;
  for (const auto& p : points) {
    const Polar q = polar_of(robot, p);
    if (q.range_m <= goal_range_m) pts.push_back(q);
  }
  return pts;
}

/// Each sector's representative: its nearest point (spec §7.3).
std::vector<int> nearest_per_sector(const NavigationFilter& filter, const std::vector<Polar>& pts) {
  const int n = filter.sector_count();
  std::vector<int> nearest(static_cast<std::size_t>(n), -1);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    int& k = nearest[static_cast<std::size_t>(filter.sector_of(pts[i].bearing_rad))];
    if (k < 0 || pts[i].range_m < pts[static_cast<std::size_t>(k)].range_m) k = static_cast<int>(i);
  }
  return nearest;
}

/// S1 [ours]: through a gap wider than W_gap but narrower than 2·S_dist both edges are inside
/// S_dist: attracted by the goal beyond the gap's edge, the field held the robot in front of it
/// (a corridor with 1 m gaps, spec §11 item 19 (e)). The bearing of the middle of the gap ahead
/// nearest the attraction's direction (it attracts instead; the edges' repulsion centres the
/// robot); nullopt when there is none.
std::optional<double> gap_ahead_rad(const Pose2D& robot, const std::vector<Polar>& pts, double attract_rad,
                                    double goal_bearing_rad, const PolarMapParams& params) {
  const double S = params.security_distance_m;
  std::vector<const Polar*> ahead;
  for (const auto& q : pts)
    if (in_front(q.bearing_rad)) ahead.push_back(&q);
  std::sort(ahead.begin(), ahead.end(), [](const Polar* a, const Polar* b) { return a->bearing_rad < b->bearing_rad; });
  double best = std::numeric_limits<double>::infinity();
  std::optional<double> gap_rad;
  for (std::size_t i = 1; i < ahead.size(); ++i) {
    const Polar& r = *ahead[i - 1];
    const Polar& l = *ahead[i];
    if (cv::norm(l.p - r.p) <= params.gap_width_m) continue;
    const cv::Point2d mid = 0.5 * (l.p + r.p);
    const double mid_rad = polar_of(robot, mid).bearing_rad;
    const double off = std::fabs(wrap(mid_rad - attract_rad));
    const bool towards_goal = std::fabs(wrap(mid_rad - goal_bearing_rad)) < kPi / 2;
    if (off < best && towards_goal && std::min(l.range_m, r.range_m) < S + params.gap_width_m) {
      best = off;
      gap_rad = mid_rad;
    }
  }
  return gap_rad;
}

/// S1: the potential field's decision. Attracted by `attract_rad` (the goal, or the tenacity
/// direction) or the gap ahead nearest it; repelled by each sector's representative, not every
/// stored point: summed over all of them a wall's push grew with how often it had been seen.
/// `field_side`: the side of the previous turn towards a direction behind the robot (updated).
Decision potential_field(const Pose2D& robot, double goal_bearing_rad, double attract_rad, const std::vector<Polar>& pts,
                         const std::vector<int>& nearest, const PolarMapParams& params, int& field_side) {
  const double S = params.security_distance_m;
  const std::optional<double> gap_rad = gap_ahead_rad(robot, pts, attract_rad, goal_bearing_rad, params);
  if (gap_rad) attract_rad = *gap_rad;
  const bool through_gap = gap_rad.has_value();
  double rx = 0.0, ry = 0.0;
  for (const int k : nearest) {
    if (k < 0) continue;
    const Polar& q = pts[static_cast<std::size_t>(k)];
    if (q.range_m >= S || q.range_m <= 1e-6) continue;
    const double mag = params.repulsion_gain * (1.0 / q.range_m - 1.0 / S) / (q.range_m * q.range_m);
    rx -= mag * std::cos(q.bearing_rad);
    ry -= mag * std::sin(q.bearing_rad);
  }
  const double ax = std::cos(attract_rad), ay = std::sin(attract_rad);
  if (through_gap) {
    // Into a gap only the repulsion across it acts (it centres the robot); along it, the
    // edges' push would hold the robot in front of any gap narrower than 2·S_dist.
    const double along = rx * ax + ry * ay;
    if (along < 0.0) {
      rx -= along * ax;
      ry -= along * ay;
    }
  }
  const double fx = params.attraction_gain * ax + rx, fy = params.attraction_gain * ay + ry;
  Decision d;
  d.situation = Situation::high_risk;
  d.heading_rad = std::atan2(fy, fx);
  // A field pointing nearly straight back flips between ±180° with the noise, and the robot
  // turning towards it alternately left and right never turns: keep the side of the turn
  // while the field points behind the robot.
  if (std::fabs(d.heading_rad) > kPi / 2 && field_side != 0) d.heading_rad = field_side * std::fabs(d.heading_rad);
  field_side = std::fabs(d.heading_rad) > kPi / 2 ? (d.heading_rad > 0 ? 1 : -1) : 0;
  d.translate = true;
  d.reason = "obstacle within the security distance: potential field";
  return d;
}

/// ε = asin(S_dist / d): the angle by which a point at range d is passed.
double eps_of(double S, double range_m) { return std::asin(std::min(1.0, S / range_m)); }

/// GF: the goal sector is free. The decision (without the reset that follows it) when the gap
/// between the first occupied sectors left and right is not forbidden; nullopt otherwise (GO).
std::optional<Decision> goal_sector_free(const std::vector<Polar>& pts, const std::vector<int>& nearest, const Polar& goal,
                                         int goal_sector, const PolarMapParams& params) {
  const int n = static_cast<int>(nearest.size());
  std::optional<Polar> left, right;
  for (int s = 1; s <= n / 2 && !left; ++s)
    if (int k = nearest[static_cast<std::size_t>((goal_sector + s) % n)]; k >= 0) left = pts[static_cast<std::size_t>(k)];
  for (int s = 1; s <= n / 2 && !right; ++s)
    if (int k = nearest[static_cast<std::size_t>((goal_sector - s + n) % n)]; k >= 0) right = pts[static_cast<std::size_t>(k)];
  const bool forbidden = left && right && cv::norm(left->p - right->p) < params.gap_width_m;
  if (forbidden) return std::nullopt;
  Decision d;
  d.translate = true;
  d.heading_rad = goal.bearing_rad;
  d.situation = Situation::goal_free;
  d.reason = "goal sector free";
  const Polar* px = nullptr;
  bool px_is_right = false;
  if (left && right) {
    const bool lf = in_front(left->bearing_rad), rf = in_front(right->bearing_rad);
    if (lf != rf) px_is_right = rf;
    else px_is_right = right->range_m < left->range_m;
    px = px_is_right ? &*right : &*left;
  } else if (left || right) {
    px_is_right = static_cast<bool>(right);
    px = right ? &*right : &*left;
  }
  if (px != nullptr) {
    const double eps = eps_of(params.security_distance_m, px->range_m);
    if (std::fabs(wrap(goal.bearing_rad - px->bearing_rad)) <= eps) {  // (6.3) violated
      d.heading_rad = wrap(px_is_right ? px->bearing_rad + eps : px->bearing_rad - eps);
      d.situation = Situation::goal_grazing;
      d.reason = std::string("goal sector free, passing the ") + (px_is_right ? "right" : "left") + " point at " +
                 std::to_string(px->range_m) + " m";
    }
  }
  return d;
}

/// GO: the searches over angularly consecutive points from the goal direction.
class GapSearch {
 public:
  GapSearch(const NavigationFilter& filter, const PolarMapParams& params, const std::vector<Polar>& pts)
      : filter_(filter), params_(params), pts_(pts), S_(params.security_distance_m) {}

  /// The counter-clockwise (`ccw`) and clockwise (`cw`) candidates from the goal's bearing.
  void search(double goal_bearing_rad, std::optional<Candidate>& ccw, std::optional<Candidate>& cw) const {
    std::vector<Polar> sorted = pts_;
    std::sort(sorted.begin(), sorted.end(), [](const Polar& a, const Polar& b) { return a.bearing_rad < b.bearing_rad; });
    const std::size_t m = sorted.size();
    if (m < 1) return;
    // index of the first point CCW of the goal (bearing relative to the goal in (0, 2π])
    auto rel = [&](const Polar& q) {
      double a = wrap(q.bearing_rad - goal_bearing_rad);
      return a <= 0 ? a + 2 * kPi : a;
    };
    std::vector<std::size_t> order(m);
    for (std::size_t i = 0; i < m; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rel(sorted[a]) < rel(sorted[b]); });
    // order[0] is the first point CCW of the goal, order[m−1] the first CW of it.
    for (std::size_t s = 0; s < m && !ccw; ++s) {
      const Polar& r = sorted[order[(s + m - 1) % m]];
      const Polar& l = sorted[order[s]];
      if (m == 1) break;
      ccw = gap_candidate(r, l, 1);
    }
    for (std::size_t s = 0; s < m && !cw; ++s) {
      const Polar& l = sorted[order[(m - s) % m]];
      const Polar& r = sorted[order[m - 1 - s]];
      if (m == 1) break;
      cw = gap_candidate(r, l, -1);
    }
    if (m == 1) {  // one point: pass it on the side nearer the goal
      const Polar& x = sorted[0];
      const double eps = eps_of(S_, x.range_m);
      const double hl = wrap(x.bearing_rad + eps), hr = wrap(x.bearing_rad - eps);
      if (validate(hl)) ccw = Candidate{hl, Situation::gap_end_behind, "single point, passing it on its left"};
      if (validate(hr)) cw = Candidate{hr, Situation::gap_end_behind, "single point, passing it on its right"};
    }
  }

 private:
  /// A candidate whose sector holds a point nearer than S_dist + step_m is rejected.
  [[nodiscard]] bool validate(double heading_rad) const {
    const int k = filter_.sector_of(heading_rad);
    return std::none_of(pts_.begin(), pts_.end(), [&](const Polar& q) {
      return filter_.sector_of(q.bearing_rad) == k && q.range_m < S_ + params_.step_m;
    });
  }

  // Gap between angularly consecutive points r (right) and l (left: CCW of r), reached by the
  // search going CCW (side +1) or CW (side −1). Every gap must be wider than W_gap [spec I for
  // Case 3]. When the free arc from r to l passes behind the robot, or one end is behind
  // (Case 3), only the end the search came along matters: pass it on the free side.
  [[nodiscard]] std::optional<Candidate> gap_candidate(const Polar& r, const Polar& l, int side) const {
    const bool rf = in_front(r.bearing_rad), lf = in_front(l.bearing_rad);
    if (!rf && !lf) return std::nullopt;
    double arc = l.bearing_rad - r.bearing_rad;
    if (arc <= 0) arc += 2 * kPi;
    const bool through_back = r.bearing_rad + arc > kPi;
    // Both ends ahead and the free arc between them passing behind the robot: the ends are the
    // two sides of one obstacle with nothing else stored (a lone box), and the gap is everything
    // behind the robot, not the chord between them (session 13, spec §11 item 19 (b)).
    const bool lone_obstacle = rf && lf && through_back;
    if (!lone_obstacle && cv::norm(l.p - r.p) <= params_.gap_width_m) return std::nullopt;
    if (rf != lf || through_back) {
      const Polar& x = rf != lf ? (rf ? r : l) : (side > 0 ? r : l);
      const bool x_is_right = &x == &r;
      const double eps = eps_of(S_, x.range_m);
      if (x.range_m <= S_) return std::nullopt;
      const double h = wrap(x_is_right ? x.bearing_rad + eps : x.bearing_rad - eps);
      if (!validate(h)) return std::nullopt;
      return Candidate{h, Situation::gap_end_behind, std::string("passing the obstacle's ") + (x_is_right ? "left" : "right") + " end"};
    }
    const bool x_is_right = r.range_m <= l.range_m;
    const Polar& x = x_is_right ? r : l;
    if (x.range_m <= S_) return std::nullopt;
    const double eps = eps_of(S_, x.range_m);
    const double h = wrap(x_is_right ? x.bearing_rad + eps : x.bearing_rad - eps);
    if (!validate(h)) return std::nullopt;
    return Candidate{h, Situation::gap, "gap of " + std::to_string(cv::norm(l.p - r.p)) + " m"};
  }

  const NavigationFilter& filter_;
  const PolarMapParams& params_;
  const std::vector<Polar>& pts_;
  double S_;
};

/// GO's side: the tenacity side once chosen, else the smaller deviation from the goal (which
/// then sets `tenacity_side`).
std::optional<Candidate> choose_candidate(const std::optional<Candidate>& ccw, const std::optional<Candidate>& cw,
                                          bool tenacity_on, int& tenacity_side, double goal_bearing_rad) {
  std::optional<Candidate> chosen;
  if (ccw && cw) {
    if (tenacity_on) {
      chosen = tenacity_side > 0 ? ccw : cw;
    } else {
      const bool left_smaller = std::fabs(wrap(ccw->heading_rad - goal_bearing_rad)) <= std::fabs(wrap(cw->heading_rad - goal_bearing_rad));
      chosen = left_smaller ? ccw : cw;
      tenacity_side = left_smaller ? 1 : -1;
    }
  } else if (ccw || cw) {
    chosen = ccw ? ccw : cw;
    if (!tenacity_on) tenacity_side = ccw ? 1 : -1;
  }
  return chosen;
}

}  // namespace

Decision NavigationFilter::decide(const Pose2D& robot, const cv::Point2d& goal_m) {
  Decision d;
  const Polar goal = polar_of(robot, goal_m);
  // S0
  if (goal.range_m < params_.goal_tolerance_m) {
    reset();
    d.situation = Situation::goal_reached;
    d.reset = true;
    d.reason = "goal reached";
    return d;
  }
  const std::vector<Polar> pts = points_nearer_than_goal(points_, robot, goal.range_m);
  const double S = params_.security_distance_m;
  const std::vector<int> nearest = nearest_per_sector(*this, pts);
  // S1: the potential field.
  const bool high_risk = std::any_of(pts.begin(), pts.end(), [&](const Polar& q) { return q.range_m < S; });
  if (high_risk) {
    // Attracted by the goal, or, while an obstacle is being bypassed (tenacity), by the
    // direction of the last gap taken: pulled towards the goal beside a wall end, the robot
    // turned back into the U it was leaving (spec §11 item 19 (c)).
    const double attract_rad = tenacity_on_ ? wrap(tenacity_heading_world_rad_ - robot.heading_rad) : goal.bearing_rad;
    return potential_field(robot, goal.bearing_rad, attract_rad, pts, nearest, params_, field_side_);
  }
  const int goal_sector = sector_of(goal.bearing_rad);
  // GF: goal sector free.
  if (nearest[static_cast<std::size_t>(goal_sector)] < 0) {
    if (std::optional<Decision> gf = goal_sector_free(pts, nearest, goal, goal_sector, params_)) {
      d = std::move(*gf);
      reset(robot);
      d.reset = true;
      return d;
    }
  }
  // GO: searches over angularly consecutive points from the goal direction.
  std::optional<Candidate> ccw, cw;
  GapSearch(*this, params_, pts).search(goal.bearing_rad, ccw, cw);
  const std::optional<Candidate> chosen = choose_candidate(ccw, cw, tenacity_on_, tenacity_side_, goal.bearing_rad);
  if (!chosen) {
    d.situation = Situation::no_candidate;
    d.translate = false;
    // Rotate towards the tenacity side, else keep the side of the first blocked cycle (the
    // side of minimum turn then): re-deciding every cycle would swing back and forth.
    if (!tenacity_on_ && rotate_side_ == 0) rotate_side_ = goal.bearing_rad >= 0 ? 1 : -1;
    const int side = tenacity_on_ ? tenacity_side_ : rotate_side_;
    d.heading_rad = side * kPi / 2;
    d.reason = "goal direction blocked and no gap of " + std::to_string(params_.gap_width_m) + " m: rotating in place";
    return d;
  }
  tenacity_on_ = true;
  tenacity_heading_world_rad_ = wrap(chosen->heading_rad + robot.heading_rad);
  rotate_side_ = 0;
  d.situation = chosen->situation;
  d.heading_rad = chosen->heading_rad;
  d.translate = true;
  d.reason = chosen->reason + (tenacity_side_ > 0 ? ", left side" : ", right side");
  // S9: the obstacle is passed when nothing stored is ahead any more.
  if (std::none_of(pts.begin(), pts.end(), [](const Polar& q) { return in_front(q.bearing_rad); })) {
    reset(robot);
    d.reset = true;
  }
  return d;
}

}  // namespace visnav::ipt
