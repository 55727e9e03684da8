// visual_memory_lateral — how a lateral start offset decays on a visual-memory edge, per control
// law and lateral gain, over several seeds with the error models on (docs/visual_memory.md,
// "Convergence from a lateral error"). The rig is plugins/primitives/visual_memory/eval: a 14 m
// edge on straight15m taught per seed, replayed from ±offset with its own seed.
// Usage: visual_memory_lateral [--seeds N] [--offset M] [--gains K1,K2,...] [--controllers C1,C2,...]
//                              [--length M] [--trace]
// --trace prints every frame (true pose, reference, lateral estimate against the truth) to stderr.
// Prints one row per (controller, gain): edges ended on the goal image / by odometry, the lateral offset at half the edge and at the
// goal (mean ± sd of |y| and the worst), the overshoot across the line, and the decay rate k
// (|y| = |y0| e^(−k x)) from the mean end offset, and the mean |bias| of the follower's lateral
// estimate against the truth. Exit 1 on bad arguments or a rig error.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "closed_loop.hpp"

namespace vm = visnav::visual_memory;
namespace ev = visnav::visual_memory::eval;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

struct Stats {
  std::vector<double> v;
  [[nodiscard]] double mean() const {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / static_cast<double>(v.size());
  }
  [[nodiscard]] double sd() const {
    if (v.size() < 2) return 0.0;
    const double m = mean();
    double s = 0.0;
    for (double x : v) s += (x - m) * (x - m);
    return std::sqrt(s / static_cast<double>(v.size() - 1));
  }
  [[nodiscard]] double max() const {
    double m = 0.0;
    for (double x : v) m = std::max(m, x);
    return m;
  }
};

int usage(const char* why) {
  std::fprintf(stderr,
               "visual_memory_lateral: %s\nusage: visual_memory_lateral [--seeds N] [--offset M] [--gains K1,K2,...] "
               "[--controllers C1,C2,...] [--length M]\n",
               why);
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 5;
  double offset_m = 0.5, length_m = 14.0;
  std::vector<double> gains = {0.0, 0.5, 1.0};
  std::vector<std::string> controllers = {"centroid", "IJCU"};
  bool trace = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--trace") {
      trace = true;
      continue;
    }
    if (i + 1 >= argc) return usage(("missing value after " + a).c_str());
    const std::string v = argv[++i];
    char* end = nullptr;
    if (a == "--seeds") {
      seeds = static_cast<int>(std::strtol(v.c_str(), &end, 10));
      if (*end != '\0' || seeds < 1 || seeds > 100) return usage("--seeds takes 1-100");
    } else if (a == "--offset") {
      offset_m = std::strtod(v.c_str(), &end);
      if (*end != '\0' || !(offset_m > 0.0 && offset_m <= 2.0)) return usage("--offset takes (0, 2] m");
    } else if (a == "--length") {
      length_m = std::strtod(v.c_str(), &end);
      if (*end != '\0' || !(length_m >= 4.0 && length_m <= 14.5)) return usage("--length takes [4, 14.5] m");
    } else if (a == "--gains") {
      gains.clear();
      for (const auto& g : split(v)) {
        const double k = std::strtod(g.c_str(), &end);
        if (*end != '\0' || !(k >= 0.0 && k <= 10.0)) return usage(("bad gain '" + g + "' (0-10 rad/s per m)").c_str());
        gains.push_back(k);
      }
    } else if (a == "--controllers") {
      controllers = split(v);
      for (const auto& c : controllers)
        if (!vm::controller_from_string(c)) return usage(("unknown controller '" + c + "'").c_str());
    } else {
      return usage(("unknown option " + a).c_str());
    }
  }
  auto world = ev::rig_world(VISNAV_TEST_SOURCE_DIR);
  if (!world.ok()) return usage(world.error().message.c_str());

  std::vector<vm::VisualMemory> taught;
  for (int s = 0; s < seeds; ++s) {
    auto memory = ev::rig_teach(*world, 100 + s, length_m);
    if (!memory.ok()) return usage(("teach failed: " + memory.error().message).c_str());
    std::fprintf(stderr, "taught seed %d: %zu references\n", 100 + s, memory->references.size());
    taught.push_back(std::move(*memory));
  }
  std::printf("%.1f m edge on straight15m, start offset ±%.2f m, %d seeds × 2 sides, error models on\n\n", length_m,
              offset_m, seeds);
  std::printf("| controller | k_y (rad/s per m) | goal image / ended by odometry | |y| at half [m] | |y| at the end [m] | "
              "worst at the end [m] | overshoot [m] | k [1/m] | |lateral estimate bias| [m] |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& controller : controllers) {
    for (double k_y : gains) {
      vm::ReplayParams p;
      p.controller = controller;
      p.lateral_gain_radps_per_m = k_y;
      Stats half, end;
      double overshoot = 0.0, travelled = 0.0;
      int goals = 0, by_odometry = 0, runs = 0;
      Stats estimate_bias;
      for (int s = 0; s < seeds; ++s) {
        for (const double side : {1.0, -1.0}) {
          const double y0 = side * offset_m;
          auto print = [&](const vm::FollowStep& step, const visnav::Pose2D& truth) {
            std::fprintf(stderr, "  x %6.2f y %+.3f heading %+.3f | ref %2d pose %d tracked %3d/%3d lateral %+.3f (true %+.3f) "
                         "omega %+.3f\n", truth.x_m, truth.y_m, truth.heading_rad, step.target, step.pose_ok ? 1 : 0,
                         step.tracked_3d, step.tracked, step.lateral_m, -truth.y_m, step.command.angular_radps);
          };
          auto o = ev::rig_replay(*world, taught[static_cast<std::size_t>(s)], p, 200 + 2 * s + (side > 0 ? 0 : 1),
                                  visnav::Pose2D{0.0, y0, 0.0}, {},
                                  trace ? std::function<void(const vm::FollowStep&, const visnav::Pose2D&)>(print) : nullptr);
          if (!o.ok()) return usage(("replay failed: " + o.error().message).c_str());
          ++runs;
          if (o->goal) ++goals;  // an edge that fails or ends by odometry is counted, not dropped
          if (o->ended_by_odometry) ++by_odometry;
          estimate_bias.v.push_back(std::abs(o->lateral_error_mean_m));
          half.v.push_back(std::abs(o->y_at_half_m));
          end.v.push_back(std::abs(o->end.y_m));
          overshoot = std::max(overshoot, -o->end.y_m * side);  // across the line, at the end
          travelled += o->end.x_m;
          std::fprintf(stderr,
                       "%s k_y %.2f seed %d y0 %+.2f: %s, y at half %+.3f, end %+.3f at x %.2f; lateral estimate "
                       "error %+.3f mean, %.3f rms over %d frames\n",
                       controller.c_str(), k_y, s, y0,
                       o->goal ? "goal" : (o->failed ? o->failure.c_str() : (o->ended_by_odometry ? "ended by odometry" : "no end")),
                       o->y_at_half_m, o->end.y_m, o->end.x_m, o->lateral_error_mean_m, o->lateral_error_rms_m, o->pose_frames);
        }
      }
      const double mean_x = travelled / runs;
      const double k = std::log(offset_m / std::max(1e-3, end.mean())) / std::max(1.0, mean_x);
      std::printf("| %s | %.2f | %d / %d of %d | %.3f ± %.3f | %.3f ± %.3f | %.3f | %.3f | %.3f | %.3f |\n",
                  controller.c_str(), k_y, goals, by_odometry, runs, half.mean(), half.sd(), end.mean(), end.sd(), end.max(),
                  std::max(0.0, overshoot), k, estimate_bias.mean());
      std::fflush(stdout);
    }
  }
  return 0;
}
