// Per-frame cost of the segmentation-based path follower (issue 5) and the share of it spent in
// the Felzenszwalb-Huttenlocher graph segmentation. Single-threaded (cv::setNumThreads(1)).
// Targets at 320×240: ≤ 25 ms per frame (seed 000 Sec. 6.2 reports 215 ms), everything but the
// segmentation ≤ 30 % of the total.
//
// Counters (thread CPU time, so that other processes on a shared machine do not inflate them):
// frame_ms (whole process() call), segmentation_ms (the segmentation step of the same frame —
// resize to seg_scale, graph segmentation, nearest-neighbour label upscale — re-run outside the
// timed region with the follower's parameters), segmentation_share = segmentation_ms / frame_ms,
// rest_share = 1 − segmentation_share. The benchmark's own Time column is wall time.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/segmentation.hpp>

#include "synthetic.hpp"
#include "visnav/path_following/path_follower.hpp"
#ifdef VISNAV_BENCH_HAVE_SIM
#include <numbers>
#include <string>

#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"
#endif

namespace pf = visnav::path_following;

namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::vector<cv::Mat> make_frames(int width, int height) {
  std::vector<cv::Mat> frames;
  const double s = width / 320.0;
  for (int i = 0; i < 8; ++i) {
    pf::testing::SceneSpec spec;
    spec.width = width;
    spec.height = height;
    spec.horizon_row = static_cast<int>(height * (0.27 + 0.02 * (i % 3)));
    const double shift = (i - 4) * 12.0 * s;
    const double bend = (i % 2 == 0 ? 1.0 : -1.0) * 40.0 * s;
    spec.centre_px = [=](double t) { return width / 2.0 + shift + bend * (1.0 - t) * (1.0 - t); };
    spec.half_width_far_px = 12.0 * s;
    spec.half_width_near_px = 80.0 * s;
    spec.seed = static_cast<std::uint32_t>(100 + i);
    frames.push_back(pf::testing::make_scene(spec).bgr);
  }
  return frames;
}

#ifdef VISNAV_BENCH_HAVE_SIM
// Frames rendered by the simulator on the straight6m world's gravel path (on and beside it).
std::vector<cv::Mat> make_sim_frames(int width, int height) {
  std::vector<cv::Mat> frames;
  auto world = visnav::sim::load_world(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/straight6m.yaml");
  if (!world) return frames;
  visnav::sim::CameraModel model;
  model.width_px = width;
  model.height_px = height;
  visnav::sim::Renderer renderer(*world, model);
  for (int i = 0; i < 8; ++i) {
    cv::Mat bgr;
    const double heading = (i % 3 - 1) * 10.0 * std::numbers::pi / 180.0;
    renderer.render(visnav::Pose2D{0.6 * i, (i % 5 - 2) * 0.2, heading}, bgr);
    frames.push_back(bgr);
  }
  return frames;
}
#endif

void run_frames(benchmark::State& state, const std::vector<cv::Mat>& frames, const char* label) {
  if (frames.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  const int width = frames.front().cols;
  const int height = frames.front().rows;
  auto follower = std::move(pf::PathFollower::create(pf::PathFollowerParams{}).value());
  const auto& p = follower.params();
  const int min_size = std::max(1, static_cast<int>(std::lround(p.seg_min_size_px * p.seg_scale * p.seg_scale)));
  auto segmenter = cv::ximgproc::segmentation::createGraphSegmentation(p.seg_sigma, static_cast<float>(p.seg_k),
                                                                       min_size);
  pf::PathEstimate estimate;
  cv::Mat small, small_labels, labels;
  // Warm-up: buffers sized once.
  for (const auto& f : frames) (void)follower.process(f, estimate);

  double frame_s = 0.0, seg_s = 0.0;
  std::size_t n = 0, ok_frames = 0;
  for (auto _ : state) {
    const cv::Mat& frame = frames[n % frames.size()];
    const double t0 = thread_cpu_s();
    const auto status = follower.process(frame, estimate);
    const double t1 = thread_cpu_s();
    benchmark::DoNotOptimize(estimate.command);
    state.PauseTiming();
    if (!status.ok()) {
      state.SkipWithError(status.error().message.c_str());
      break;
    }
    if (estimate.status == pf::PathStatus::ok) ++ok_frames;
    const cv::Mat blurred = follower.stages().blurred;
    const double t2 = thread_cpu_s();
    if (p.seg_scale < 1.0) {
      cv::resize(blurred, small, cv::Size(), p.seg_scale, p.seg_scale, cv::INTER_AREA);
      segmenter->processImage(small, small_labels);
      cv::resize(small_labels, labels, blurred.size(), 0.0, 0.0, cv::INTER_NEAREST);
    } else {
      segmenter->processImage(blurred, labels);
    }
    const double t3 = thread_cpu_s();
    benchmark::DoNotOptimize(labels.data);
    frame_s += t1 - t0;
    seg_s += t3 - t2;
    ++n;
    state.ResumeTiming();
  }
  if (n == 0) return;
  const double frame_ms = 1e3 * frame_s / static_cast<double>(n);
  const double seg_ms = 1e3 * seg_s / static_cast<double>(n);
  state.counters["frame_ms"] = frame_ms;
  state.counters["segmentation_ms"] = seg_ms;
  state.counters["segmentation_share"] = seg_ms / frame_ms;
  state.counters["rest_share"] = 1.0 - seg_ms / frame_ms;
  state.counters["ok_frames_share"] = static_cast<double>(ok_frames) / static_cast<double>(n);
  if (width == 320 && height == 240) {
    std::printf("path_following %s @320x240 (CPU): %.2f ms per frame (target <= 25 ms: %s), segmentation %.2f ms = %.0f %%, "
                "rest %.0f %% (target <= 30 %%: %s)\n",
                label, frame_ms, frame_ms <= 25.0 ? "met" : "MISSED", seg_ms, 100.0 * seg_ms / frame_ms,
                100.0 * (1.0 - seg_ms / frame_ms), 1.0 - seg_ms / frame_ms <= 0.30 ? "met" : "MISSED");
  }
}

void BM_PathFollowerSynthetic(benchmark::State& state) {
  cv::setNumThreads(1);
  run_frames(state, make_frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))), "synthetic");
}

#ifdef VISNAV_BENCH_HAVE_SIM
void BM_PathFollowerSimulator(benchmark::State& state) {
  cv::setNumThreads(1);
  run_frames(state, make_sim_frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))),
             "simulator");
}
#endif

}  // namespace

BENCHMARK(BM_PathFollowerSynthetic)->Args({320, 240})->Args({640, 480})->Unit(benchmark::kMillisecond)->MinTime(2.0);
#ifdef VISNAV_BENCH_HAVE_SIM
BENCHMARK(BM_PathFollowerSimulator)->Args({320, 240})->Args({640, 480})->Unit(benchmark::kMillisecond)->MinTime(2.0);
#endif

BENCHMARK_MAIN();
