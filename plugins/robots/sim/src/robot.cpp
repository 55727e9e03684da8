// Robot kinematics, odometry model and the `sim` robot object.
#include "visnav_sim/robot.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>


namespace visnav::sim {
namespace {

constexpr double kDeg = CV_PI / 180.0;

std::uint64_t freeze_seed(int seed) { return static_cast<std::uint64_t>(seed) * 0x9E3779B97F4A7C15ULL + 13; }

double wrap_angle(double a) {
  a = std::fmod(a + CV_PI, 2.0 * CV_PI);
  if (a < 0) a += 2.0 * CV_PI;
  return a - CV_PI;
}

double approach(double current, double target, double max_delta) {
  if (target > current) return std::min(target, current + max_delta);
  return std::max(target, current - max_delta);
}

}  // namespace

Status RobotParams::validate() const {
  if (!start_pose.empty() && start_pose.size() != 3)
    return fail("key 'start_pose': expected 3 values x_m;y_m;heading_deg, got " + std::to_string(start_pose.size()));
  if (kinematics == "car_like" && !(min_turning_radius_m > 0))
    return fail("key 'min_turning_radius_m': must be > 0 for car_like kinematics");
  if (freeze_max_s < freeze_min_s)
    return Error{"key 'freeze_max_s': " + std::to_string(freeze_max_s) + " is below freeze_min_s " + std::to_string(freeze_min_s),
                 ErrorCode::inconsistent, ErrorLocation({}, 0, "freeze_max_s")};
  return ok();
}

const ParamSchema<RobotParams>& RobotParams::schema() {
  static const auto s =
      ParamSchema<RobotParams>{}
          .field("world", &RobotParams::world, "world file or name (config/worlds/<name>.yaml); empty = none")
          .field("obstacles", &RobotParams::obstacles, "obstacle file added to the world for this run (YAML 'obstacles:' list, docs/sim.md); empty = none")
          .field("kinematics", &RobotParams::kinematics, "drive model").one_of({"diff_drive", "car_like", "tracked"})
          .field("max_linear_mps", &RobotParams::max_linear_mps, "forward speed limit, m/s").range(0.01, 20)
          .field("max_reverse_mps", &RobotParams::max_reverse_mps, "reverse speed limit, m/s").range(0, 20)
          .field("max_angular_radps", &RobotParams::max_angular_radps, "yaw rate limit, rad/s").range(0.01, 20)
          .field("linear_accel_mps2", &RobotParams::linear_accel_mps2, "linear acceleration limit, m/s^2").range(0.01, 100)
          .field("angular_accel_radps2", &RobotParams::angular_accel_radps2, "angular acceleration limit, rad/s^2").range(0.01, 200)
          .field("min_turning_radius_m", &RobotParams::min_turning_radius_m, "car_like: minimum turning radius, m").range(0.01, 100)
          .field("track_slip", &RobotParams::track_slip, "tracked: fraction of the commanded yaw rate lost to skid").range(0, 0.9)
          .field("actuation_delay_s", &RobotParams::actuation_delay_s, "delay before a command takes effect, s").range(0, 5)
          .field("command_timeout_s", &RobotParams::command_timeout_s, "watchdog: stop after this long without a command, s; 0 = off").range(0, 3600)
          .field("integration_step_s", &RobotParams::integration_step_s, "longest integration sub-step, s").range(1e-4, 0.1)
          .field("start_pose", &RobotParams::start_pose, "x_m;y_m;heading_deg in the world; empty = the world's start")
          .field("displacement_lateral_m", &RobotParams::displacement_lateral_m, "initial displacement to the left of the start pose, m").range(-100, 100)
          .field("displacement_longitudinal_m", &RobotParams::displacement_longitudinal_m, "initial displacement forward of the start pose, m").range(-100, 100)
          .field("displacement_heading_deg", &RobotParams::displacement_heading_deg, "initial heading offset, deg (CCW +)").range(-180, 180)
          .field("odom_rate_hz", &RobotParams::odom_rate_hz, "odometry publication rate, Hz (simulated time)").range(0.1, 1000)
          .field("odom_scale_error_pct", &RobotParams::odom_scale_error_pct, "odometric distance scale error, %").range(-50, 50)
          .field("odom_heading_drift_degpm", &RobotParams::odom_heading_drift_degpm, "odometric heading drift, deg per metre travelled").range(-90, 90)
          .field("odom_distance_noise_m_per_sqrt_m", &RobotParams::odom_distance_noise_m_per_sqrt_m, "distance noise std, m per sqrt(m) travelled").range(0, 1)
          .field("odom_heading_noise_deg_per_sqrt_m", &RobotParams::odom_heading_noise_deg_per_sqrt_m, "heading noise std, deg per sqrt(m) travelled").range(0, 45)
          .field("odom_scale_error_sd_pct", &RobotParams::odom_scale_error_sd_pct, "per-run std of the scale error, %").range(0, 50)
          .field("odom_wheel_asymmetry_pct", &RobotParams::odom_wheel_asymmetry_pct, "right wheel larger than the left, % (odometric heading drift)").range(-20, 20)
          .field("odom_wheel_asymmetry_sd_pct", &RobotParams::odom_wheel_asymmetry_sd_pct, "per-run std of the wheel asymmetry, %").range(0, 20)
          .field("odom_heading_drift_sd_degpm", &RobotParams::odom_heading_drift_sd_degpm, "per-run std of the heading drift, deg/m").range(0, 90)
          .field("track_width_m", &RobotParams::track_width_m, "wheel separation used by the asymmetry model, m").range(0.05, 10)
          .field("slip_path_pct", &RobotParams::slip_path_pct, "wheel slip on paths (gravel): body moves this % less than the wheels").range(0, 50)
          .field("slip_grass_pct", &RobotParams::slip_grass_pct, "wheel slip on grass, %").range(0, 50)
          .field("slip_other_pct", &RobotParams::slip_other_pct, "wheel slip on pavement, floor and other ground, %").range(0, 50)
          .field("body_radius_m", &RobotParams::body_radius_m, "collision disc radius, m; 0 = no collisions").range(0, 10)
          .field("body_height_m", &RobotParams::body_height_m, "walls whose base is higher are passed under, m").range(0.05, 10)
          .field("trunk_radius_m", &RobotParams::trunk_radius_m, "tree trunks are discs of this radius, m").range(0.01, 5)
          .field("freeze_rate_per_min", &RobotParams::freeze_rate_per_min, "compute freezes per minute of simulated time; 0 = none").range(0, 600)
          .field("freeze_min_s", &RobotParams::freeze_min_s, "shortest compute freeze, s").range(0.01, 9)
          .field("freeze_max_s", &RobotParams::freeze_max_s, "longest compute freeze, s").range(0.01, 9)
          .field("seed", &RobotParams::seed, "seed of the run's error draw and of the odometry noise").range(0, 2147483647)
          .field("pose_history_s", &RobotParams::pose_history_s, "ground-truth history kept for camera latency, s").range(0.1, 600);
  return s;
}

RunErrors draw_run_errors(const RobotParams& params) {
  // A generator of its own, so the draw does not depend on how much noise was consumed.
  std::mt19937_64 rng(static_cast<std::uint64_t>(params.seed) * 0xD1B54A32D192ED03ULL + 7);
  std::normal_distribution<double> unit(0.0, 1.0);
  RunErrors e;
  e.scale_error_pct = params.odom_scale_error_pct + params.odom_scale_error_sd_pct * unit(rng);
  e.wheel_asymmetry_pct = params.odom_wheel_asymmetry_pct + params.odom_wheel_asymmetry_sd_pct * unit(rng);
  e.heading_drift_degpm = params.odom_heading_drift_degpm + params.odom_heading_drift_sd_degpm * unit(rng);
  return e;
}

std::vector<CollisionShape> collision_shapes(const World& world, double body_height_m, double trunk_radius_m) {
  std::vector<CollisionShape> shapes;
  for (const Wall& w : world.walls) {
    if (w.base_m >= body_height_m) continue;  // lintels, signs: the body passes under
    if (w.label == LabelClass::tree) {
      // A tree is two crossed billboards around its trunk: one disc at their common centre.
      const cv::Point2d c = 0.5 * (w.from + w.to);
      const bool seen = std::any_of(shapes.begin(), shapes.end(), [&](const CollisionShape& s) {
        return s.name == w.name && cv::norm(s.from - c) < 1e-6;
      });
      if (!seen) shapes.push_back({c, c, trunk_radius_m, w.name});
      continue;
    }
    shapes.push_back({w.from, w.to, 0.0, w.name, w.mover});
  }
  return shapes;
}

namespace {

/// Distance from `p` to the shape displaced by `offset` (a moving obstacle's; zero otherwise).
double distance_to_shape(const CollisionShape& s, const cv::Point2d& p, const cv::Point2d& offset = {0, 0}) {
  const cv::Point2d d = s.to - s.from;
  const cv::Point2d from = s.from + offset;
  const double len2 = d.dot(d);
  const double t = len2 > 0.0 ? std::clamp((p - from).dot(d) / len2, 0.0, 1.0) : 0.0;
  return cv::norm(p - (from + t * d)) - s.radius_m;
}

}  // namespace

Pose2D resolve_start(const RobotParams& params, const World* world) {
  Pose2D start;
  if (params.start_pose.size() == 3) start = Pose2D{params.start_pose[0], params.start_pose[1], params.start_pose[2] * kDeg};
  else if (world != nullptr) start = world->start;
  const double c = std::cos(start.heading_rad), s = std::sin(start.heading_rad);
  start.x_m += c * params.displacement_longitudinal_m - s * params.displacement_lateral_m;
  start.y_m += s * params.displacement_longitudinal_m + c * params.displacement_lateral_m;
  start.heading_rad = wrap_angle(start.heading_rad + params.displacement_heading_deg * kDeg);
  return start;
}

RobotCore::RobotCore(RobotParams params, Pose2D start_world, std::shared_ptr<const World> world)
    : params_(std::move(params)), world_(std::move(world)), pose_(start_world), rng_(static_cast<std::uint64_t>(params_.seed)),
      freeze_rng_(freeze_seed(params_.seed)) {
  run_errors_ = draw_run_errors(params_);
  movers_.reset(world_.get(), 0.0);
  if (world_ && params_.body_radius_m > 0.0) {
    shapes_ = collision_shapes(*world_, params_.body_height_m, params_.trunk_radius_m);
    in_contact_.assign(shapes_.size(), 0);
    // A robot placed touching an obstacle starts in contact with it (no collision recorded).
    for (std::size_t i = 0; i < shapes_.size(); ++i)
      in_contact_[i] = distance_to_shape(shapes_[i], {pose_.x_m, pose_.y_m}, shape_offset(i, 0.0)) < params_.body_radius_m ? 1 : 0;
  }
  published_.timestamp_s = 0.0;
  next_publish_s_ = 1.0 / params_.odom_rate_hz;
  history_.emplace_back(0.0, pose_);
}

void RobotCore::set_world(std::shared_ptr<const World> world) {
  std::lock_guard lock(mutex_);
  world_ = std::move(world);
  movers_.reset(world_.get(), time_s_);
  shapes_.clear();
  in_contact_.clear();
  if (world_ && params_.body_radius_m > 0.0) {
    shapes_ = collision_shapes(*world_, params_.body_height_m, params_.trunk_radius_m);
    in_contact_.assign(shapes_.size(), 0);
    for (std::size_t i = 0; i < shapes_.size(); ++i)
      in_contact_[i] = distance_to_shape(shapes_[i], {pose_.x_m, pose_.y_m}, shape_offset(i, time_s_)) < params_.body_radius_m ? 1 : 0;
  }
}

RobotParams RobotCore::params() const {
  std::lock_guard lock(mutex_);
  return params_;
}

void RobotCore::set_params(const RobotParams& params) {
  std::lock_guard lock(mutex_);
  RobotParams p = params;
  p.world = params_.world;
  p.kinematics = params_.kinematics;
  p.start_pose = params_.start_pose;
  p.displacement_lateral_m = params_.displacement_lateral_m;
  p.displacement_longitudinal_m = params_.displacement_longitudinal_m;
  p.displacement_heading_deg = params_.displacement_heading_deg;
  p.body_radius_m = params_.body_radius_m;  // the collision shapes were built for the body
  p.body_height_m = params_.body_height_m;
  p.trunk_radius_m = params_.trunk_radius_m;
  const bool new_run = p.seed != params_.seed;
  params_ = p;
  if (new_run) {
    // A new seed is a new run: new systematic errors and a new noise stream.
    run_errors_ = draw_run_errors(params_);
    rng_.seed(static_cast<std::uint64_t>(params_.seed));
    freeze_rng_.seed(freeze_seed(params_.seed));
  }
}

int RobotCore::freeze_count() const {
  std::lock_guard lock(mutex_);
  return freeze_count_;
}

double RobotCore::frozen_s() const {
  std::lock_guard lock(mutex_);
  return frozen_s_;
}

RunErrors RobotCore::run_errors() const {
  std::lock_guard lock(mutex_);
  return run_errors_;
}

std::vector<SimCollision> RobotCore::collisions() const {
  std::lock_guard lock(mutex_);
  return collisions_;
}

void RobotCore::command(const Twist& twist) {
  std::lock_guard lock(mutex_);
  pending_.emplace_back(time_s_ + params_.actuation_delay_s, twist);
}

Status RobotCore::step(double dt_s) {
  if (!std::isfinite(dt_s) || dt_s <= 0.0 || dt_s > 10.0)
    return fail("sim robot: step(dt_s) needs 0 < dt_s <= 10, got " + std::to_string(dt_s));
  std::lock_guard lock(mutex_);
  bool froze = false;
  if (params_.freeze_rate_per_min > 0.0) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    if (unit(freeze_rng_) < 1.0 - std::exp(-params_.freeze_rate_per_min * dt_s / 60.0)) {
      const double freeze_s = params_.freeze_min_s + (params_.freeze_max_s - params_.freeze_min_s) * unit(freeze_rng_);
      ++freeze_count_;
      frozen_s_ += freeze_s;
      dt_s += freeze_s;  // the caller's next step comes this much later in simulated time
      froze = true;
    }
  }
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / params_.integration_step_s - 1e-9)));
  const double h = dt_s / n;
  for (int i = 0; i < n; ++i) {
    substep_locked(h);
    if (froze) history_.emplace_back(time_s_, pose_);  // a delayed camera looks into the freeze
  }
  if (time_s_ >= next_publish_s_ - 1e-9) {
    publish_locked();
    const double period = 1.0 / params_.odom_rate_hz;
    while (next_publish_s_ <= time_s_ + 1e-9) next_publish_s_ += period;
  }
  history_.emplace_back(time_s_, pose_);
  while (history_.size() > 2 && history_[1].first < time_s_ - params_.pose_history_s) history_.pop_front();
  return ok();
}

void RobotCore::substep_locked(double dt) {
  // commands whose actuation delay has passed
  while (!pending_.empty() && pending_.front().first <= time_s_ + 1e-12) {
    target_ = pending_.front().second;
    last_command_s_ = pending_.front().first;
    commanded_ = true;
    pending_.pop_front();
  }
  Twist goal = commanded_ ? target_ : Twist{};
  if (params_.command_timeout_s > 0.0 && time_s_ - last_command_s_ > params_.command_timeout_s + 1e-12) goal = Twist{};
  const double v_goal = std::clamp(goal.linear_mps, -params_.max_reverse_mps, params_.max_linear_mps);
  const double w_goal = std::clamp(goal.angular_radps, -params_.max_angular_radps, params_.max_angular_radps);
  velocity_.linear_mps = approach(velocity_.linear_mps, v_goal, params_.linear_accel_mps2 * dt);
  velocity_.angular_radps = approach(velocity_.angular_radps, w_goal, params_.angular_accel_radps2 * dt);
  if (params_.kinematics == "car_like") {
    const double w_max = std::abs(velocity_.linear_mps) / params_.min_turning_radius_m;
    velocity_.angular_radps = std::clamp(velocity_.angular_radps, -w_max, w_max);
  }
  const double v_wheels = velocity_.linear_mps;
  const double w_cmd = velocity_.angular_radps;
  double slip_pct = params_.slip_other_pct;
  if (world_ && (params_.slip_path_pct > 0.0 || params_.slip_grass_pct > 0.0 || params_.slip_other_pct > 0.0)) {
    const LabelClass ground = world_->ground_label_at(pose_.x_m, pose_.y_m);
    if (ground == LabelClass::path) slip_pct = params_.slip_path_pct;
    else if (ground == LabelClass::grass) slip_pct = params_.slip_grass_pct;
  }
  const double v = v_wheels * (1.0 - slip_pct / 100.0);
  const double w = params_.kinematics == "tracked" ? (1.0 - params_.track_slip) * w_cmd : w_cmd;
  const double th = pose_.heading_rad;
  const Pose2D before = pose_;
  if (std::abs(w) < 1e-9) {
    pose_.x_m += v * dt * std::cos(th);
    pose_.y_m += v * dt * std::sin(th);
  } else {
    const double r = v / w;
    pose_.x_m += r * (std::sin(th + w * dt) - std::sin(th));
    pose_.y_m += -r * (std::cos(th + w * dt) - std::cos(th));
  }
  pose_.heading_rad = wrap_angle(th + w * dt);
  double ds = v * dt;
  double ds_wheels = v_wheels * dt;
  bool blocked = false;
  movers_.advance(time_s_, dt, {before.x_m, before.y_m}, params_.body_radius_m, params_.pose_history_s);
  if (!shapes_.empty()) {
    const cv::Point2d p0(before.x_m, before.y_m), p1(pose_.x_m, pose_.y_m);
    for (std::size_t i = 0; i < shapes_.size(); ++i) {
      const cv::Point2d off1 = shape_offset(i, time_s_ + dt);
      const double d1 = distance_to_shape(shapes_[i], p1, off1);
      if (d1 >= params_.body_radius_m) {
        in_contact_[i] = 0;
        continue;
      }
      if (shapes_[i].mover >= 0) {
        // A moving obstacle: contact when it came closer (by its motion or ours); the robot is
        // held back only if its own step brought it closer.
        const double d0 = distance_to_shape(shapes_[i], p0, shape_offset(i, time_s_));
        if (d1 < d0) {
          // One contact per obstacle, not per face of its ring.
          bool touching = false;
          for (std::size_t j = 0; j < shapes_.size(); ++j) touching = touching || (in_contact_[j] && shapes_[j].mover == shapes_[i].mover);
          if (!touching) collisions_.push_back(SimCollision{time_s_ + dt, before, shapes_[i].name});
          in_contact_[i] = 1;
        }
        if (distance_to_shape(shapes_[i], p0, off1) <= d1) continue;
      } else {
        const double d0 = distance_to_shape(shapes_[i], p0);
        if (d1 >= d0) continue;  // touching but moving away (or along): allowed
      }
      // Blocked: the step is not taken and the robot stops against the obstacle.
      pose_ = before;
      velocity_ = Twist{};
      ds = 0.0;
      ds_wheels = 0.0;
      blocked = true;
      if (!in_contact_[i]) collisions_.push_back(SimCollision{time_s_ + dt, before, shapes_[i].name});
      in_contact_[i] = 1;
      break;
    }
  }
  true_distance_m_ += ds;

  // Odometry measures the wheels: slip is invisible, and so is a tracked robot's skid (the
  // tracks turn as commanded).
  const double dth_measured_true = blocked ? 0.0 : w_cmd * dt;
  const double ads = std::abs(ds_wheels);
  std::normal_distribution<double> unit(0.0, 1.0);
  double ds_m = ds_wheels * (1.0 + run_errors_.scale_error_pct / 100.0);
  double dth_m = dth_measured_true + run_errors_.wheel_asymmetry_pct / 100.0 * ds_wheels / params_.track_width_m +
                 run_errors_.heading_drift_degpm * kDeg * ads;
  if (params_.odom_distance_noise_m_per_sqrt_m > 0.0 && ads > 0.0)
    ds_m += params_.odom_distance_noise_m_per_sqrt_m * std::sqrt(ads) * unit(rng_);
  if (params_.odom_heading_noise_deg_per_sqrt_m > 0.0 && ads > 0.0)
    dth_m += params_.odom_heading_noise_deg_per_sqrt_m * kDeg * std::sqrt(ads) * unit(rng_);
  const double mid = odom_pose_.heading_rad + 0.5 * dth_m;
  odom_pose_.x_m += ds_m * std::cos(mid);
  odom_pose_.y_m += ds_m * std::sin(mid);
  odom_pose_.heading_rad = wrap_angle(odom_pose_.heading_rad + dth_m);
  odom_distance_m_ += ds_m;
  odom_window_distance_m_ += ds_m;
  odom_window_heading_rad_ += dth_m;
  time_s_ += dt;
}

void RobotCore::publish_locked() {
  const double window = time_s_ - last_publish_s_;
  published_.timestamp_s = time_s_;
  published_.pose = odom_pose_;
  published_.distance_m = odom_distance_m_;
  if (window > 1e-12) {
    published_.twist.linear_mps = odom_window_distance_m_ / window;
    published_.twist.angular_radps = odom_window_heading_rad_ / window;
  }
  odom_window_distance_m_ = 0.0;
  odom_window_heading_rad_ = 0.0;
  last_publish_s_ = time_s_;
}

double RobotCore::time_s() const {
  std::lock_guard lock(mutex_);
  return time_s_;
}

Pose2D RobotCore::ground_truth() const {
  std::lock_guard lock(mutex_);
  return pose_;
}

Pose2D RobotCore::pose_at(double t) const {
  std::lock_guard lock(mutex_);
  if (history_.empty() || t >= history_.back().first) return pose_;
  if (t <= history_.front().first) return history_.front().second;
  auto it = std::lower_bound(history_.begin(), history_.end(), t, [](const auto& e, double v) { return e.first < v; });
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double k = (t - a.first) / std::max(1e-12, b.first - a.first);
  Pose2D p;
  p.x_m = a.second.x_m + k * (b.second.x_m - a.second.x_m);
  p.y_m = a.second.y_m + k * (b.second.y_m - a.second.y_m);
  p.heading_rad = wrap_angle(a.second.heading_rad + k * wrap_angle(b.second.heading_rad - a.second.heading_rad));
  return p;
}

cv::Point2d RobotCore::mover_offset(const World* world, int mover, double time_s) const {
  std::lock_guard lock(mutex_);
  if (world != movers_.world()) return world->movers[static_cast<std::size_t>(mover)].offset_at(time_s);
  return movers_.offset_at(mover, time_s);
}

void RobotCore::teleport(const Pose2D& pose_world) {
  std::lock_guard lock(mutex_);
  pose_ = pose_world;
  pose_.heading_rad = wrap_angle(pose_.heading_rad);
  history_.clear();
  history_.emplace_back(time_s_, pose_);
}

Odometry RobotCore::odometry() const {
  std::lock_guard lock(mutex_);
  return published_;
}

Twist RobotCore::true_twist() const {
  std::lock_guard lock(mutex_);
  Twist t = velocity_;
  if (params_.kinematics == "tracked") t.angular_radps *= 1.0 - params_.track_slip;
  return t;
}

double RobotCore::true_distance_m() const {
  std::lock_guard lock(mutex_);
  return true_distance_m_;
}

// ---------------------------------------------------------------------------------------

SimRobot::SimRobot(std::shared_ptr<RobotCore> core) : core_(std::move(core)) {}

SimRobot::~SimRobot() = default;

Result<std::unique_ptr<SimRobot>> SimRobot::create(const RobotParams& params, const std::string& relative_to) {
  VISNAV_TRY(params.validate());
  std::shared_ptr<const World> world;
  if (!params.world.empty()) {
    auto path = resolve_world_path(params.world, relative_to);
    if (!path) return path.error().with_context("key 'world'");
    auto loaded = load_world_with_obstacles(*path, params.obstacles, relative_to);
    if (!loaded) return loaded.error().with_context(params.obstacles.empty() ? "key 'world'" : "key 'obstacles'");
    world = *loaded;
  } else if (!params.obstacles.empty()) {
    return Error{"key 'obstacles': needs a 'world' to add them to", ErrorCode::missing, ErrorLocation({}, 0, "world")};
  }
  auto core = std::make_shared<RobotCore>(params, resolve_start(params, world.get()), world);
  return std::unique_ptr<SimRobot>(new SimRobot(std::move(core)));
}

std::vector<Error> SimRobot::check_params(const ConfigNode& params) {
  std::vector<Error> problems = RobotParams::schema().problems(params);
  if (!problems.empty()) return problems;
  auto p = RobotParams::schema().parse(params);
  if (p && !p->world.empty())
    if (auto st = check_world_file(p->world, params); !st) problems.push_back(std::move(st).error());
  if (p && p->world.empty() && !p->obstacles.empty())
    problems.push_back(Error{params.where().str() + ": key 'obstacles': needs a 'world' to add them to", ErrorCode::missing,
                             ErrorLocation(params.where().file, params.where().line, "world")});
  if (p && problems.empty() && !p->obstacles.empty()) {
    // Report a bad obstacle file before the run (at the file's line, else at the key).
    auto path = resolve_world_path(p->world, params.where().file);
    auto world = path ? load_world_with_obstacles(*path, p->obstacles, params.where().file)
                      : Result<std::shared_ptr<const World>>(path.error());
    if (!world) problems.push_back(world.error().with_context("key 'obstacles'"));
  }
  return problems;
}

Result<std::unique_ptr<SimRobot>> SimRobot::create(const ConfigNode& params, HostServices& host) {
  if (auto problems = check_params(params); !problems.empty()) return std::move(problems.front());
  VISNAV_ASSIGN(RobotParams p, RobotParams::schema().parse(params));
  auto made = create(p, params.where().file);
  if (!made) return made.error().with_context(params.where().str());
  const Pose2D s = (*made)->core_->ground_truth();
  const RunErrors e = (*made)->core_->run_errors();
  host.logger().info("sim robot", "(" + p.kinematics + ") starts at x=" + std::to_string(s.x_m) +
                                      " y=" + std::to_string(s.y_m) + " heading=" + std::to_string(s.heading_rad / kDeg) + " deg" +
                                      (p.world.empty() ? std::string() : " in world '" + p.world + "'") +
                                      "; run errors: scale " + std::to_string(e.scale_error_pct) + " %, wheel asymmetry " +
                                      std::to_string(e.wheel_asymmetry_pct) + " %, drift " +
                                      std::to_string(e.heading_drift_degpm) + " deg/m");
  (*made)->logger_ = &host.logger();
  return made;
}

Status SimRobot::reconfigure(const ConfigNode& params) {
  VISNAV_ASSIGN(RobotParams p, RobotParams::schema().parse(params));
  const RobotParams cur = core_->params();
  if (p.world != cur.world || p.kinematics != cur.kinematics || p.start_pose != cur.start_pose ||
      p.displacement_lateral_m != cur.displacement_lateral_m || p.displacement_longitudinal_m != cur.displacement_longitudinal_m ||
      p.displacement_heading_deg != cur.displacement_heading_deg)
    return fail("sim robot: world, kinematics, start_pose and displacement_* cannot change while running");
  if (p.obstacles != cur.obstacles) {
    // Obstacles placed for the next run (visnav experiment --obstacles: the replay only).
    if (p.world.empty()) return Error{"key 'obstacles': needs a 'world' to add them to", ErrorCode::missing, {{}, 0, "world"}};
    auto path = resolve_world_path(p.world, params.where().file);
    if (!path) return path.error().with_context("key 'world'");
    auto world = load_world_with_obstacles(*path, p.obstacles, params.where().file);
    if (!world) return world.error().with_context("key 'obstacles'");
    core_->set_world(*world);
  }
  core_->set_params(p);
  return ok();
}

Status SimRobot::send_command(const Twist& command) {
  if (!std::isfinite(command.linear_mps) || !std::isfinite(command.angular_radps))
    return fail("sim robot: command is not finite");
  core_->command(command);
  return ok();
}

std::optional<Odometry> SimRobot::latest_odometry() { return core_->odometry(); }
std::vector<SimCollision> SimRobot::collisions() const { return core_->collisions(); }
Status SimRobot::step(double dt_s) {
  VISNAV_TRY(core_->step(dt_s));
  // A collision is an outcome of the run (issue 16): say so in the log, once per contact.
  if (logger_ != nullptr) {
    const auto all = core_->collisions();
    for (; collisions_logged_ < all.size(); ++collisions_logged_) {
      const SimCollision& c = all[collisions_logged_];
      logger_->warn("sim robot", "collision with '" + c.obstacle + "' at t=" + std::to_string(c.time_s) + " s, x=" +
                                     std::to_string(c.pose_world.x_m) + " y=" + std::to_string(c.pose_world.y_m));
    }
  }
  return ok();
}
double SimRobot::time_s() const { return core_->time_s(); }
Pose2D SimRobot::ground_truth_pose() const { return core_->ground_truth(); }
Status SimRobot::set_ground_truth_pose(const Pose2D& pose_world) {
  if (!std::isfinite(pose_world.x_m) || !std::isfinite(pose_world.y_m) || !std::isfinite(pose_world.heading_rad))
    return fail("sim robot: set_ground_truth_pose needs a finite pose");
  core_->teleport(pose_world);
  return ok();
}

}  // namespace visnav::sim
