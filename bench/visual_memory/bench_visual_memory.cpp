// bench_visual_memory — one replay frame of a visual_memory edge at 640×480 (issue 15 target:
// ≤ 15 ms on 2 cores), next to the feature primitive's cycle (bench_feature_replay):
//   * replay/<controller>/threads:<n>: MemoryFollower::step on a sequence of frames rendered
//     along the taught line 0.2 m to its left (straight15m, 640×480, 60° hfov): frame-to-frame
//     KLT of the reference's features, PnP, reprojection of the 3D points (resume/drop),
//     switching and the control law; the counter ms_per_frame is the mean over the frames;
//   * teach/<estimator>/threads:<n>: MemoryTeacher::add_frame on the taught frames (KLT, the
//     reference-to-frame 5-point check and, at new references, triangulation and Harris), with
//     OpenCV's RANSAC and with our MLESAC (300 minimal samples).
// Frames and the memory are made once, outside the timing. OpenCV threads as in the name
// (cv::setNumThreads).
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/visual_memory/follower.hpp"
#include "visnav/visual_memory/teacher.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace vm = visnav::visual_memory;
namespace sim = visnav::sim;

namespace {

constexpr double kLength = 6.0;
constexpr double kStep = 0.05;

struct Data {
  std::vector<cv::Mat> teach_frames;
  std::vector<cv::Mat> replay_frames;
  vm::VisualMemory memory;
};

const Data& data() {
  static const Data d = [] {
    Data r;
    auto world = sim::load_world(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/straight15m.yaml");
    if (!world.ok()) return r;
    sim::CameraModel cam;
    cam.width_px = 640;
    cam.height_px = 480;
    sim::Renderer renderer(*world, cam);
    auto teacher = vm::MemoryTeacher::create(vm::TeachParams{});
    for (double x = 0.0; x <= kLength + 1e-9; x += kStep) {
      cv::Mat bgr;
      renderer.render(visnav::Pose2D{x, 0.0, 0.0}, bgr);
      r.teach_frames.push_back(bgr);
      visnav::Odometry odom;
      odom.pose = {x, 0.0, 0.0};
      odom.distance_m = x;
      (void)teacher->add_frame(bgr, odom, x);
      cv::Mat off;
      renderer.render(visnav::Pose2D{x, 0.2, -0.02}, off);
      r.replay_frames.push_back(off);
    }
    r.memory = std::move(teacher->finish().value());
    return r;
  }();
  return d;
}

void replay(benchmark::State& state, const std::string& controller) {
  cv::setNumThreads(static_cast<int>(state.range(0)));
  const Data& d = data();
  if (d.memory.references.empty()) {
    state.SkipWithError("world not found");
    return;
  }
  vm::ReplayParams p;
  p.controller = controller;
  std::unique_ptr<vm::MemoryFollower> follower;
  std::size_t i = 0;
  std::int64_t frames = 0, tracked = 0;
  double wall_s = 0.0;
  auto restart = [&] {
    follower = std::make_unique<vm::MemoryFollower>(vm::MemoryFollower::create(p, d.memory, kLength).value());
    (void)follower->step(d.replay_frames[0], 0.0);  // initial localisation (ORB), not timed
    i = 1;
  };
  restart();
  for (auto _ : state) {
    if (i >= d.replay_frames.size()) {
      state.PauseTiming();
      restart();
      state.ResumeTiming();
    }
    const auto t0 = std::chrono::steady_clock::now();
    const vm::FollowStep s = follower->step(d.replay_frames[i], static_cast<double>(i) * kStep);
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(s.command);
    tracked += s.tracked;
    ++frames;
    ++i;
  }
  state.counters["ms_per_frame"] = frames > 0 ? 1e3 * wall_s / static_cast<double>(frames) : 0.0;
  state.counters["tracked_mean"] = frames > 0 ? static_cast<double>(tracked) / static_cast<double>(frames) : 0.0;
}

void teach(benchmark::State& state, const std::string& estimator) {
  vm::TeachParams tp;
  tp.estimator = estimator;
  cv::setNumThreads(static_cast<int>(state.range(0)));
  const Data& d = data();
  std::int64_t frames = 0;
  double wall_s = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    auto teacher = vm::MemoryTeacher::create(tp).value();
    state.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < d.teach_frames.size(); ++k) {
      visnav::Odometry odom;
      odom.pose = {static_cast<double>(k) * kStep, 0.0, 0.0};
      odom.distance_m = static_cast<double>(k) * kStep;
      benchmark::DoNotOptimize(teacher.add_frame(d.teach_frames[k], odom, odom.distance_m));
      ++frames;
    }
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  state.counters["ms_per_frame"] = frames > 0 ? 1e3 * wall_s / static_cast<double>(frames) : 0.0;
}

}  // namespace

BENCHMARK_CAPTURE(replay, centroid, std::string("centroid"))->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(replay, IJC, std::string("IJC"))->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(replay, IJCU, std::string("IJCU"))->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(teach, ransac, std::string("ransac"))->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK_CAPTURE(teach, mlesac, std::string("mlesac"))->Arg(1)->ArgName("threads")->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
