// visual_memory_compare — seed 004's comparison (Sec. VI, Tables I-II, the convergence domain)
// in the simulator, for docs/visual_memory.md:
//   * the courtyard world config/worlds/curve20m.yaml (photo panels 3-4 m away, like the
//     paper's sparse near scene), a taught path of 1 m straight then a 110° left arc of radius
//     2.2 m (about 5.2 m; seed 004: 4.8 m, N = 17, -110°), 640×480, 60° hfov, the camera 0.1 m
//     ahead of the rotation axis (δ), 10 Hz lock-step, v̄ = 0.2 m/s;
//   * the simulator's error models on (config/sim_experiment.yaml's odometry and camera errors;
//     own seeds for teach and replay);
//   * per controller: average ε_i w.r.t. I_i (the smallest image error reached while I_i was
//     the target, px), average position error at the references (true position when I_i is
//     passed vs. the true position where I_i was taught, cm), average tracked features n, and
//     the same with coarse calibration (±10 % on the focal length and δ, and on z̄ for IJPU/
//     IJCU, signs drawn per controller; the path is taught again with that calibration);
//   * λ = a = 1, z̄ = 5 m, switching by the pose (seed 003; see docs for seed 004's rule here);
//   * convergence domain: lateral start offsets 0, 0.2, … m until the goal is not reached within
//     0.5 m; ρ = ε_1 at the largest converging offset / ε_1 at the taught start.
// Usage: visual_memory_compare [--quick] (--quick: 320×240, offsets up to 0.6 m)
//        visual_memory_compare --domain N [--quick]: only the convergence domain, over N replay
//        seeds (41, 42, ...), offsets 0.2 … 1.6 m.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "visnav/visual_memory/follower.hpp"
#include "visnav/visual_memory/teacher.hpp"
#include "visnav_sim/camera.hpp"
#include "visnav_sim/robot.hpp"
#include "visnav_sim/world.hpp"

namespace vm = visnav::visual_memory;
namespace sim = visnav::sim;

namespace {

constexpr double kDt = 0.1;
constexpr double kSpeed = 0.2;
constexpr double kStraight = 1.0, kRadius = 2.2, kArcRad = 110.0 * 3.14159265358979 / 180.0;
constexpr double kDelta = 0.1;
const visnav::Pose2D kStart{-1.0, -3.5, 0.0};  // the arc passes 2 m from the pillar

int g_width = 640, g_height = 480;
bool g_trace = false;
double g_lambda = 1.0;
std::string g_switch_rule = "pose";

sim::RobotParams robot_params(int seed) {
  sim::RobotParams p;
  p.seed = seed;
  p.actuation_delay_s = 0.05;
  p.odom_scale_error_sd_pct = 3;
  p.odom_wheel_asymmetry_sd_pct = 0.2;
  p.odom_heading_drift_sd_degpm = 0.05;
  p.odom_distance_noise_m_per_sqrt_m = 0.01;
  p.odom_heading_noise_deg_per_sqrt_m = 0.5;
  p.slip_path_pct = 3;
  p.slip_grass_pct = 5;
  p.slip_other_pct = 0.5;
  return p;
}

sim::CameraParams camera_params(int seed) {
  sim::CameraParams c;
  c.seed = seed;
  c.width_px = g_width;
  c.height_px = g_height;
  c.mount_forward_m = kDelta;
  c.noise_std = 3;
  c.exposure_jitter = 0.06;
  c.motion_blur_exposure_s = 0.01;
  c.latency_s = 0.05;
  c.drop_probability = 0.03;
  return c;
}

struct Rig {
  std::shared_ptr<sim::RobotCore> robot;
  std::unique_ptr<sim::CameraCore> camera;
  Rig(std::shared_ptr<const sim::World> world, int seed, const visnav::Pose2D& start) {
    robot = std::make_shared<sim::RobotCore>(robot_params(seed), start, world);
    camera = std::make_unique<sim::CameraCore>(camera_params(seed), robot, world);
  }
};

struct Taught {
  vm::VisualMemory memory;
  std::vector<visnav::Pose2D> reference_truth;  ///< true pose where each reference was taught
  double length_m = 0.0;
};

/// Teaches the path with the camera model `camera` (the coarse runs teach with their own
/// miscalibration, as a robot with that calibration would).
Taught teach(const std::shared_ptr<const sim::World>& world, const vm::CameraParams& camera = {}) {
  Rig rig(world, 7, kStart);
  vm::TeachParams tp;
  tp.camera = camera;
  auto teacher = vm::MemoryTeacher::create(tp).value();
  Taught t;
  double heading_turned = 0.0;
  std::size_t refs = 0;
  for (int i = 0; i < 10000 && heading_turned < kArcRad; ++i) {
    const double d = rig.robot->odometry().distance_m;
    const double w = d < kStraight ? 0.0 : kSpeed / kRadius;
    rig.robot->command({kSpeed, w});
    (void)rig.robot->step(kDt);
    heading_turned = rig.robot->ground_truth().heading_rad - kStart.heading_rad;
    if (auto f = rig.camera->grab()) {
      (void)teacher.add_frame(f->image, rig.robot->odometry(), rig.robot->odometry().distance_m);
      while (refs < teacher.memory().references.size()) {
        t.reference_truth.push_back(rig.camera->last_pose());
        ++refs;
      }
    }
  }
  t.length_m = rig.robot->odometry().distance_m;
  t.memory = teacher.finish().value();
  if (t.reference_truth.size() < t.memory.references.size()) t.reference_truth.push_back(rig.camera->last_pose());
  return t;
}

struct Metrics {
  bool goal = false;
  double mean_error_px = 0.0;
  double mean_position_cm = 0.0;
  double mean_n = 0.0;
  double first_error_px = 0.0;
  double end_error_m = 0.0;
};

Metrics replay(const std::shared_ptr<const sim::World>& world, const Taught& t, const vm::ReplayParams& p, int seed,
               double lateral_m) {
  const visnav::Pose2D start{kStart.x_m, kStart.y_m + lateral_m, kStart.heading_rad};
  Rig rig(world, seed, start);
  auto follower = vm::MemoryFollower::create(p, t.memory, t.length_m).value();
  Metrics m;
  const std::size_t n_ref = t.memory.references.size();
  std::vector<double> min_error(n_ref, -1.0);
  double pos_sum = 0.0;
  int pos_count = 0;
  long tracked_sum = 0, frames = 0;
  visnav::Twist cmd;
  int target = follower.target();
  bool first = true;
  // a run that neither reaches the goal nor fails within twice the taught duration has not converged
  const int max_steps = static_cast<int>(2.0 * t.length_m / kSpeed / kDt) + 100;
  for (int i = 0; i < max_steps; ++i) {
    rig.robot->command(cmd);
    (void)rig.robot->step(kDt);
    auto f = rig.camera->grab();
    if (!f) continue;
    const vm::FollowStep s = follower.step(f->image, rig.robot->odometry().distance_m);
    cmd = s.command;
    if (s.status == vm::FollowStatus::failed) break;
    if (s.tracked > 0) {
      tracked_sum += s.tracked;
      ++frames;
    }
    const visnav::Pose2D truth = rig.robot->ground_truth();
    if (g_trace)
      std::printf("t %.1f d %.2f target %d %s tracked %d/%d eps %.1f w %+.3f v %.2f truth (%.2f, %.2f, %.1f deg) %s\n",
                  rig.robot->time_s(), rig.robot->odometry().distance_m, s.target, vm::to_string(s.status), s.tracked,
                  s.tracked_3d, s.image_error_px, s.command.angular_radps, s.command.linear_mps, truth.x_m, truth.y_m,
                  truth.heading_rad * 57.2958, s.detail.c_str());
    if (s.target != target || s.finished()) {
      // I_target passed: position error against where it was taught
      const visnav::Pose2D& r = t.reference_truth[static_cast<std::size_t>(target)];
      pos_sum += std::hypot(truth.x_m - r.x_m, truth.y_m - r.y_m);
      ++pos_count;
      target = s.target;
    }
    if (!s.finished() && s.tracked > 0) {
      if (first) {
        m.first_error_px = s.image_error_px;
        first = false;
      }
      double& e = min_error[static_cast<std::size_t>(s.target)];
      if (e < 0.0 || s.image_error_px < e) e = s.image_error_px;
    }
    if (s.finished()) {
      m.goal = s.status == vm::FollowStatus::goal;
      const visnav::Pose2D& r = t.reference_truth.back();
      m.end_error_m = std::hypot(truth.x_m - r.x_m, truth.y_m - r.y_m);
      break;
    }
  }
  double e_sum = 0.0;
  int e_count = 0;
  for (double e : min_error)
    if (e >= 0.0) {
      e_sum += e;
      ++e_count;
    }
  m.mean_error_px = e_count > 0 ? e_sum / e_count : 0.0;
  m.mean_position_cm = pos_count > 0 ? 100.0 * pos_sum / pos_count : 0.0;
  m.mean_n = frames > 0 ? static_cast<double>(tracked_sum) / static_cast<double>(frames) : 0.0;
  return m;
}

vm::ReplayParams params_for(const std::string& controller, bool coarse, std::mt19937& rng) {
  vm::ReplayParams p;
  p.controller = controller;
  p.speed_mps = kSpeed;
  p.turn_speed_mps = kSpeed;
  p.camera.camera_forward_m = kDelta;
  p.uniform_depth_m = 5.0;
  p.lambda = g_lambda;
  p.centroid_gain_radps = g_lambda;
  p.switch_rule = g_switch_rule;
  p.lateral_gain_radps_per_m = 0.0;  // seed 004's laws exactly (the lateral term is ours: visual_memory_lateral)
  if (coarse) {
    std::bernoulli_distribution sign(0.5);
    auto factor = [&] { return sign(rng) ? 1.1 : 0.9; };
    const double f = (g_width / 2.0) / std::tan(30.0 * 3.14159265358979 / 180.0) * factor();
    p.camera.horizontal_fov_deg = 2.0 * std::atan((g_width / 2.0) / f) * 180.0 / 3.14159265358979;
    p.camera.camera_forward_m = kDelta * factor();
    if (controller == "IJPU" || controller == "IJCU") p.uniform_depth_m *= factor();
  }
  return p;
}

/// The replayed controllers, in table order.
const char* const kControllers[] = {"RH", "IJP", "IJPU", "IJC", "IJCU", "AIJCA", "centroid"};

/// --trace CONTROLLER OFFSET [LAMBDA [SWITCH_RULE [coarse]]]: one replay, every frame.
int run_trace(int argc, char** argv) {
  g_trace = true;
  g_width = 320;
  g_height = 240;
  auto w = sim::load_world(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/curve20m.yaml");
  if (!w.ok()) return 1;
  std::mt19937 rng0(1);
  const vm::ReplayParams traced = params_for(argv[2], argc > 6, rng0);
  const Taught t = teach(*w, traced.camera);
  for (std::size_t k = 0; k < t.reference_truth.size(); ++k)
    std::printf("ref %zu at %.2f m: truth (%.2f, %.2f), %d 3D\n", k, t.memory.references[k].distance_m,
                t.reference_truth[k].x_m, t.reference_truth[k].y_m, t.memory.references[k].count_3d());
  if (argc > 4) g_lambda = std::atof(argv[4]);
  if (argc > 5) g_switch_rule = argv[5];
  vm::ReplayParams p = traced;
  p.lambda = p.centroid_gain_radps = g_lambda;
  p.switch_rule = g_switch_rule;
  if (const visnav::Status st = p.validate(); !st) {
    std::fprintf(stderr, "visual_memory_compare --trace: %s\n", st.error().message.c_str());
    return 2;
  }
  const Metrics m = replay(*w, t, p, 21, std::atof(argv[3]));
  std::printf("goal %d eps %.1f pos %.0f cm n %.0f end %.0f cm\n", m.goal, m.mean_error_px, m.mean_position_cm, m.mean_n,
              100 * m.end_error_m);
  return 0;
}

/// --domain N: the convergence domain over N replay seeds.
void print_domain_over_seeds(const std::shared_ptr<const sim::World>& world, const Taught& t, int domain_seeds) {
  // The convergence domain over several replay seeds (41, 42, ...): per seed the largest lateral
  // start offset (0.2 m steps up to 1.6 m) from which the goal is still reached within 0.5 m.
  std::printf("convergence domain over %d replay seeds (largest converging offset per seed, m)\n\n"
              "| controller | per seed | mean | rho (mean) |\n|---|---|---|---|\n", domain_seeds);
  for (const char* c : kControllers) {
    std::mt19937 unused(1);
    const vm::ReplayParams p = params_for(c, false, unused);
    std::string per_seed;
    double sum_best = 0.0, sum_rho = 0.0;
    for (int k = 0; k < domain_seeds; ++k) {
      const int seed = 41 + k;
      const Metrics ideal = replay(world, t, p, seed, 0.0);
      double best = 0.0, rho = 0.0;
      for (double off = 0.2; off <= 1.6 + 1e-9; off += 0.2) {
        const Metrics m = replay(world, t, p, seed, off);
        if (!m.goal || m.end_error_m > 0.5) break;
        best = off;
        rho = ideal.first_error_px > 0.0 ? m.first_error_px / ideal.first_error_px : 0.0;
      }
      char buf[32];
      std::snprintf(buf, sizeof buf, "%s%.1f", per_seed.empty() ? "" : ", ", best);
      per_seed += buf;
      sum_best += best;
      sum_rho += rho;
    }
    std::printf("| %s | %s | %.2f | %.1f |\n", c, per_seed.c_str(), sum_best / domain_seeds, sum_rho / domain_seeds);
    std::fflush(stdout);
  }
}

/// The tables with correct and coarse calibration: mean ± sd over the replay seeds.
void print_calibration_tables(const std::shared_ptr<const sim::World>& world, const Taught& t) {
  std::mt19937 rng(2009);
  // Table rows: mean ± sd over the replay seeds (each seed draws its own odometry and camera errors).
  const int seeds[] = {21, 22, 23};
  auto mean_sd = [](const std::vector<double>& v) {
    double m = 0.0, q = 0.0;
    for (double x : v) m += x;
    m /= static_cast<double>(v.size());
    for (double x : v) q += (x - m) * (x - m);
    return std::pair<double, double>(m, std::sqrt(q / static_cast<double>(v.size())));
  };
  for (const bool coarse : {false, true}) {
    std::printf("%s calibration, %zu replay seeds (mean ± sd)\n\n"
                "| controller | goals | avg eps_i (px) | avg position error (cm) | avg n | end error (cm) |\n"
                "|---|---|---|---|---|---|\n",
                coarse ? "coarse (±10 %)" : "correct", std::size(seeds));
    for (const char* c : kControllers) {
      const vm::ReplayParams p = params_for(c, coarse, rng);
      const Taught taught_here = coarse ? teach(world, p.camera) : Taught{};
      std::vector<double> eps, pos, n, end;
      int goals = 0;
      for (int seed : seeds) {
        const Metrics m = replay(world, coarse ? taught_here : t, p, seed, 0.0);
        goals += m.goal ? 1 : 0;
        eps.push_back(m.mean_error_px);
        pos.push_back(m.mean_position_cm);
        n.push_back(m.mean_n);
        end.push_back(100.0 * m.end_error_m);
      }
      const auto [e_m, e_s] = mean_sd(eps);
      const auto [p_m, p_s] = mean_sd(pos);
      const auto [n_m, n_s] = mean_sd(n);
      const auto [d_m, d_s] = mean_sd(end);
      std::printf("| %s | %d/%zu | %.1f ± %.1f | %.1f ± %.1f | %.0f ± %.0f | %.1f ± %.1f |\n", c, goals, std::size(seeds),
                  e_m, e_s, p_m, p_s, n_m, n_s, d_m, d_s);
      std::fflush(stdout);
    }
    std::printf("\n");
  }
}

/// The convergence domain of replay seed 41 (lateral start offsets up to 0.6 m quick, else 1.2 m).
void print_convergence_domain(const std::shared_ptr<const sim::World>& world, const Taught& t, bool quick) {
  std::printf("convergence domain (lateral start offset, converged = goal within 0.5 m)\n\n"
              "| controller | largest offset (m) | rho |\n|---|---|---|\n");
  const double max_offset = quick ? 0.6 : 1.2;
  for (const char* c : kControllers) {
    std::mt19937 unused(1);
    const vm::ReplayParams p = params_for(c, false, unused);
    const Metrics ideal = replay(world, t, p, 41, 0.0);
    double best = -1.0, rho = 0.0;
    for (double off = 0.2; off <= max_offset + 1e-9; off += 0.2) {
      const Metrics m = replay(world, t, p, 41, off);
      if (!m.goal || m.end_error_m > 0.5) break;
      best = off;
      rho = ideal.first_error_px > 0.0 ? m.first_error_px / ideal.first_error_px : 0.0;
    }
    if (best < 0.0) std::printf("| %s | < 0.2 | - |\n", c);
    else std::printf("| %s | %.1f%s | %.1f |\n", c, best, best >= max_offset - 1e-9 ? " (all tried)" : "", rho);
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  if (argc > 2 && std::strcmp(argv[1], "--trace") == 0) return run_trace(argc, argv);
  int domain_seeds = 0;  // --domain N [--quick]: only the convergence domain, over N replay seeds
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--domain") == 0) domain_seeds = std::clamp(std::atoi(argv[i + 1]), 1, 20);
  if (quick || (argc > 3 && std::strcmp(argv[3], "--quick") == 0)) {
    g_width = 320;
    g_height = 240;
  }
  auto world = sim::load_world(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/curve20m.yaml");
  if (!world.ok()) {
    std::fprintf(stderr, "%s\n", world.error().message.c_str());
    return 1;
  }
  const Taught t = teach(*world);
  std::printf("taught: %.2f m, %zu references, %dx%d\n\n", t.length_m, t.memory.references.size(), g_width, g_height);
  if (domain_seeds > 0) {
    print_domain_over_seeds(*world, t, domain_seeds);
    return 0;
  }
  print_calibration_tables(*world, t);
  print_convergence_domain(*world, t, quick);
  return 0;
}
