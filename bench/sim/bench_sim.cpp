// bench_sim: render time per frame of the campus world at 320x240 and 640x480 on one core.
// Targets (issue 3): <= 4 ms and <= 15 ms per frame. Counters: ms_per_frame and
// ratio_to_target (< 1 meets the target), from the thread's CPU time so that a loaded
// machine does not distort the figure. Poses cycle along the campus route (indoor hall,
// square, gravel path) so the figure covers walls-heavy and ground-heavy views.
#include <benchmark/benchmark.h>

#include <ctime>

#include <opencv2/core/utility.hpp>

#include "visnav_sim/camera.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace vs = visnav::sim;

namespace {

/// CPU time of the calling thread, s (the figure that matters on a shared machine).
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void report(benchmark::State& state, double cpu_s, double target_ms) {
  const double ms = 1e3 * cpu_s / static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.counters["ms_per_frame"] = ms;
  if (target_ms > 0) {
    state.counters["target_ms"] = target_ms;
    state.counters["ratio_to_target"] = ms / target_ms;
  }
}

std::shared_ptr<const vs::World> campus() {
  static std::shared_ptr<const vs::World> w = [] {
    auto path = vs::resolve_world_path("campus");
    if (!path) throw std::runtime_error(path.error().message);
    auto world = vs::load_world(*path);
    if (!world) throw std::runtime_error(world.error().message);
    return *world;
  }();
  return w;
}

const visnav::Pose2D kPoses[] = {
    {7.5, -6.0, 1.5708}, {7.5, 5.0, 1.5708}, {10.0, 13.0, 0.0}, {19.0, 9.0, -1.5708}, {15.5, -3.0, -1.5708},
    {25.0, -6.0, 0.0},   {32.0, -15.0, -1.5708}, {15.0, -26.0, 3.1416}, {-2.0, -15.0, 1.5708}, {0.0, -6.0, 0.0}};

void render_bench(benchmark::State& state, bool labels) {
  cv::setNumThreads(1);
  const int width = static_cast<int>(state.range(0));
  const double target_ms = width <= 320 ? 4.0 : 15.0;
  vs::CameraModel m;
  m.width_px = width;
  m.height_px = width * 3 / 4;
  m.pitch_down_deg = 5.0;
  vs::Renderer r(campus(), m);
  cv::Mat bgr, lab;
  size_t i = 0;
  const double t0 = thread_cpu_s();
  for (auto _ : state) {
    r.render(kPoses[i++ % std::size(kPoses)], bgr, labels ? &lab : nullptr);
    benchmark::DoNotOptimize(bgr.data);
  }
  report(state, thread_cpu_s() - t0, target_ms);
}

void BM_Render(benchmark::State& state) { render_bench(state, false); }
void BM_RenderWithLabels(benchmark::State& state) { render_bench(state, true); }

/// The full camera pipeline with every appearance effect on (noise, blur, gain, shadows).
void BM_CameraAllEffects(benchmark::State& state) {
  cv::setNumThreads(1);
  const int width = static_cast<int>(state.range(0));
  vs::RobotParams rp;
  rp.start_pose = {25.0, -6.0, 0.0};
  rp.command_timeout_s = 0;
  auto robot = std::make_shared<vs::RobotCore>(rp, vs::resolve_start(rp, campus().get()), campus());
  robot->command({0.5, 0.3});
  vs::CameraParams cp;
  cp.width_px = width;
  cp.height_px = width * 3 / 4;
  cp.noise_std = 4;
  cp.motion_blur_exposure_s = 0.02;
  cp.gain = 1.2;
  cp.shadow_strength = 0.5;
  vs::CameraCore cam(cp, robot, campus());
  const double t0 = thread_cpu_s();
  for (auto _ : state) {
    if (!robot->step(0.05)) state.SkipWithError("step failed");
    auto f = cam.grab();
    benchmark::DoNotOptimize(f);
  }
  report(state, thread_cpu_s() - t0, 0.0);
}

}  // namespace

BENCHMARK(BM_Render)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderWithLabels)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CameraAllEffects)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
