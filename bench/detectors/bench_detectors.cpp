// bench_detectors: detect + describe time per detector type on a real 640×480 photo
// (python3-skimage's motorcycle_left.png, cropped), 500 target keypoints, OpenCV on one thread.
// The adaptive threshold is settled on 8 warm-up frames first, so the timed frames find ≈ the
// target. Counters: ms_per_frame (CPU time of the detecting thread), keypoints (kept), raw
// (found before the top-N cut), threshold (the adapted value). The STAR and BRIEF stages of
// star_brief are also timed on their own.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <ctime>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/detectors/brief.hpp"
#include "visnav/detectors/detector_types.hpp"
#include "visnav/detectors/star.hpp"

namespace {

namespace d = visnav::detectors;

const cv::Mat& frame() {
  static const cv::Mat image = [] {
    cv::Mat m = cv::imread("/usr/lib/python3/dist-packages/skimage/data/motorcycle_left.png", cv::IMREAD_COLOR);
    if (m.empty()) return m;
    return cv::Mat(m(cv::Rect(50, 10, 640, 480)).clone());
  }();
  return image;
}

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

void BM_DetectDescribe(benchmark::State& state, const std::string& type) {
  cv::setNumThreads(1);
  if (frame().empty()) {
    state.SkipWithError("python3-skimage photo motorcycle_left.png not found");
    return;
  }
  auto made = d::create_detector(type, d::make_params({{"target_keypoints", "500"}}));
  if (!made) {
    state.SkipWithError(made.error().message.c_str());
    return;
  }
  auto det = std::move(made).value();
  visnav::Features features;
  for (int i = 0; i < 8; ++i) (void)det->detect(frame(), features);
  double cpu_ms = 0;
  std::int64_t frames = 0;
  for (auto _ : state) {
    const double t0 = thread_cpu_ms();
    auto st = det->detect(frame(), features);
    cpu_ms += thread_cpu_ms() - t0;
    ++frames;
    if (!st) {
      state.SkipWithError(st.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(features.descriptors.data);
  }
  state.counters["ms_per_frame"] = cpu_ms / static_cast<double>(frames);
  state.counters["keypoints"] = static_cast<double>(features.keypoints.size());
  state.counters["raw"] = det->last_raw_count();
  state.counters["threshold"] = det->threshold();
}

void BM_StarOnly(benchmark::State& state) {
  cv::setNumThreads(1);
  if (frame().empty()) {
    state.SkipWithError("photo not found");
    return;
  }
  cv::Mat grey;
  cv::cvtColor(frame(), grey, cv::COLOR_BGR2GRAY);
  d::StarParams p;
  p.response_threshold = state.range(0);
  d::StarDetector star(p);
  std::vector<cv::KeyPoint> kps;
  for (auto _ : state) {
    star.detect(grey, kps);
    benchmark::DoNotOptimize(kps.data());
  }
  state.counters["keypoints"] = static_cast<double>(kps.size());
  state.counters["scales"] = star.scale_count();
}

void BM_Brief500(benchmark::State& state) {
  if (frame().empty()) {
    state.SkipWithError("photo not found");
    return;
  }
  cv::Mat grey;
  cv::cvtColor(frame(), grey, cv::COLOR_BGR2GRAY);
  d::StarParams p;
  p.response_threshold = 20;
  p.border_px = 28;
  d::StarDetector star(p);
  std::vector<cv::KeyPoint> all;
  star.detect(grey, all);
  cv::KeyPointsFilter::retainBest(all, 500);
  d::BriefParams bp;
  bp.upright = state.range(0) != 0;
  d::BriefExtractor brief(bp);
  cv::Mat desc;
  std::vector<cv::KeyPoint> kps;
  for (auto _ : state) {
    kps = all;
    brief.compute(grey, kps, desc, star.integral());
    benchmark::DoNotOptimize(desc.data);
  }
  state.counters["keypoints"] = static_cast<double>(kps.size());
}

}  // namespace

int main(int argc, char** argv) {
  for (const auto& type : d::detector_type_names())
    benchmark::RegisterBenchmark(("detect_describe/" + type).c_str(), BM_DetectDescribe, type)
        ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("star_only/threshold", BM_StarOnly)->Arg(30)->Arg(10)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("brief_500/upright", BM_Brief500)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  std::printf("detect+describe at 640x480, 500 target keypoints, cv::setNumThreads(1); ms_per_frame = thread CPU time\n");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
