// bench_feature_replay — one replay cycle (detect + describe + match + histogram vote) on a
// 640x480 frame with 500 features against a 500-feature local map:
//   * plain/orb_bfmatcher: what a user of stroll_bearnav writes — cv::ORB(500) detectAndCompute,
//     cv::BFMatcher(NORM_HAMMING).knnMatch(k=2), ratio 0.7, a histogram of 41 bins of 20 px;
//   * ours/<detector>: a visnav detector (visnav_detector_core, every type) + HeadingEstimator;
//   * match_vote/plain and match_vote/ours: the matching + voting part alone; ours uses the
//     vertical gate (±50 px), the plain pipeline compares every pair, so a like-for-like row
//     (match_vote/ours_like_for_like_no_gate_ratio_0.7: no gate, same ratio) is printed too.
//   * experiences/star_brief_3_*: star_brief + the multi-experience selector over 3 experiences
//     (one matching, two of other appearance): the per-frame cost of multi-experience maps.
// Every `ours` row reports ms_per_frame and plain_over_ours = (plain cycle time) / (this cycle
// time); targets (issue 4): star_brief <= 10 ms per cycle and plain_over_ours >= 1.5.
// Single-threaded (cv::setNumThreads(1)). The frame pair is a real photo (skimage "coffee",
// scaled) cut twice with a 17 px horizontal shift; a textured synthetic image if it is missing.
#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/heading_filter.hpp"
#include "visnav/feature_replay/heading.hpp"
#ifdef VISNAV_HAVE_DETECTOR_CORE
#include "visnav/detectors/detector_types.hpp"
#endif

namespace fr = visnav::feature_replay;

namespace {

constexpr int kShiftPx = 17;

struct Frames {
  cv::Mat reference, current;  // 640x480 grey
};

const Frames& frames() {
  static const Frames f = [] {
    Frames r;
    cv::Mat src;
    const std::string path = "/usr/lib/python3/dist-packages/skimage/data/coffee.png";
    if (std::filesystem::exists(path)) src = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (src.empty()) {
      src.create(540, 720, CV_8UC1);
      cv::randu(src, 0, 256);
      cv::GaussianBlur(src, src, cv::Size(0, 0), 2.0);
    }
    cv::resize(src, src, cv::Size(720, 540), 0, 0, cv::INTER_LINEAR);
    r.reference = src(cv::Rect(30, 30, 640, 480)).clone();
    r.current = src(cv::Rect(30 + kShiftPx, 30, 640, 480)).clone();
    return r;
  }();
  return f;
}

std::map<std::string, double>& cycle_ms() {
  static std::map<std::string, double> m;
  return m;
}

// The plain pipeline's vote: 41 bins of 20 px, offset = mean of the winning bin.
double plain_vote(const std::vector<std::vector<cv::DMatch>>& knn, const std::vector<cv::KeyPoint>& cur,
                  const std::vector<cv::KeyPoint>& map, std::vector<float>& diffs) {
  diffs.clear();
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance >= 0.7f * m[1].distance) continue;
    diffs.push_back(cur[static_cast<std::size_t>(m[0].queryIdx)].pt.x - map[static_cast<std::size_t>(m[0].trainIdx)].pt.x);
  }
  const int bins = 41, width = 20;
  int hist[41] = {0};
  for (float d : diffs) {
    const int i = static_cast<int>(std::floor((d + width * bins / 2.0) / width));
    if (i >= 0 && i < bins) ++hist[i];
  }
  int best = 0;
  for (int i = 1; i < bins; ++i) if (hist[i] > hist[best]) best = i;
  double sum = 0.0;
  int n = 0;
  for (float d : diffs) {
    const int i = static_cast<int>(std::floor((d + width * bins / 2.0) / width));
    if (i == best) { sum += d; ++n; }
  }
  return n > 0 ? sum / n : 0.0;
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

// Runs the loop; ms_per_frame is this thread's CPU time per frame (robust on a shared machine;
// everything runs on this thread with cv::setNumThreads(1)), wall_ms_per_frame the wall time.
template <typename Body>
void timed_loop(benchmark::State& state, const std::string& key, Body&& body) {
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = thread_cpu_ms();
  for (auto _ : state) body();
  const double n = static_cast<double>(state.iterations());
  const double ms = (thread_cpu_ms() - c0) / n;
  const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / n;
  cycle_ms()[key] = ms;
  state.counters["ms_per_frame"] = ms;
  state.counters["wall_ms_per_frame"] = wall;
}

void BM_plain_orb_bfmatcher(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto& f = frames();
  auto orb = cv::ORB::create(500);
  std::vector<cv::KeyPoint> map_kp, kp;
  cv::Mat map_desc, desc;
  orb->detectAndCompute(f.reference, cv::noArray(), map_kp, map_desc);
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  std::vector<float> diffs;
  double offset = 0.0;
  timed_loop(state, "plain", [&] {
    orb->detectAndCompute(f.current, cv::noArray(), kp, desc);
    matcher.knnMatch(desc, map_desc, knn, 2);
    offset = plain_vote(knn, kp, map_kp, diffs);
    benchmark::DoNotOptimize(offset);
  });
  state.counters["offset_px"] = offset;
  state.counters["features"] = static_cast<double>(kp.size());
}

void BM_match_vote_plain(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto& f = frames();
  auto orb = cv::ORB::create(500);
  std::vector<cv::KeyPoint> map_kp, kp;
  cv::Mat map_desc, desc;
  orb->detectAndCompute(f.reference, cv::noArray(), map_kp, map_desc);
  orb->detectAndCompute(f.current, cv::noArray(), kp, desc);
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  std::vector<float> diffs;
  double offset = 0.0;
  timed_loop(state, "match_vote_plain", [&] {
    matcher.knnMatch(desc, map_desc, knn, 2);
    offset = plain_vote(knn, kp, map_kp, diffs);
    benchmark::DoNotOptimize(offset);
  });
  state.counters["offset_px"] = offset;
}

// `gate`: with the vertical gate (default, max_vertical_px 50: only candidates within ±50 px rows
// are compared — the main difference to the plain pipeline, which compares every pair); without
// it the comparison is like for like (same brute-force candidate set, same 0.7 ratio test).
void match_vote_ours(benchmark::State& state, bool gate) {
  cv::setNumThreads(1);
  const auto& f = frames();
  auto orb = cv::ORB::create(500);
  visnav::Features map, cur;
  orb->detectAndCompute(f.reference, cv::noArray(), map.keypoints, map.descriptors);
  orb->detectAndCompute(f.current, cv::noArray(), cur.keypoints, cur.descriptors);
  fr::HeadingParams hp;
  if (!gate) {
    hp.max_vertical_px = 0.0;
    hp.ratio = 0.7;
  }
  fr::HeadingEstimator est(hp);
  fr::HeadingEstimate e;
  const char* key = gate ? "match_vote_ours" : "match_vote_ours_no_gate";
  timed_loop(state, key, [&] {
    auto r = est.estimate(map, cur, 640.0);
    if (r.ok()) e = *r;
    benchmark::DoNotOptimize(e);
  });
  state.counters["offset_px"] = e.offset_px;
  state.counters["inliers"] = e.inliers;
  if (cycle_ms().count("match_vote_plain") != 0)
    state.counters["plain_over_ours"] = cycle_ms()["match_vote_plain"] / cycle_ms()[key];
}
void BM_match_vote_ours(benchmark::State& state) { match_vote_ours(state, true); }
void BM_match_vote_ours_no_gate(benchmark::State& state) { match_vote_ours(state, false); }

void BM_ours_opencv_orb(benchmark::State& state) {
  // HeadingEstimator behind plain cv::ORB: isolates the matcher/vote gain when no detector core exists.
  cv::setNumThreads(1);
  const auto& f = frames();
  auto orb = cv::ORB::create(500);
  visnav::Features map, cur;
  orb->detectAndCompute(f.reference, cv::noArray(), map.keypoints, map.descriptors);
  fr::HeadingEstimator est;
  fr::HeadingEstimate e;
  timed_loop(state, "ours_opencv_orb", [&] {
    orb->detectAndCompute(f.current, cv::noArray(), cur.keypoints, cur.descriptors);
    auto r = est.estimate(map, cur, 640.0);
    if (r.ok()) e = *r;
    benchmark::DoNotOptimize(e);
  });
  state.counters["offset_px"] = e.offset_px;
  state.counters["inliers"] = e.inliers;
  if (cycle_ms().count("plain") != 0) state.counters["plain_over_ours"] = cycle_ms()["plain"] / cycle_ms()["ours_opencv_orb"];
}

#ifdef VISNAV_HAVE_DETECTOR_CORE
/// A 500-keypoint detector of `type`; null (the benchmark skipped with the reason) if it cannot be made.
std::unique_ptr<visnav::detectors::DetectorBase> bench_detector(benchmark::State& state, const std::string& type) {
  auto made = visnav::detectors::create_detector(type, visnav::detectors::make_params({{"target_keypoints", "500"}}));
  if (!made) {
    state.SkipWithError(made.error().message.c_str());
    return nullptr;
  }
  return std::move(*made);
}

/// Detects `image` into `out` after warming the adaptive threshold up on it (8 frames); false
/// (the benchmark skipped) if the detection fails.
bool warm_detect(benchmark::State& state, visnav::detectors::DetectorBase& det, const cv::Mat& image,
                 visnav::Features& out) {
  for (int i = 0; i < 8; ++i) (void)det.detect(image, out);
  if (!det.detect(image, out)) {
    state.SkipWithError("detect failed");
    return false;
  }
  return true;
}

void BM_ours_detector(benchmark::State& state, std::string type) {
  cv::setNumThreads(1);
  const auto& f = frames();
  const auto det = bench_detector(state, type);
  visnav::Features map, cur;
  if (!det || !warm_detect(state, *det, f.reference, map)) return;
  fr::HeadingEstimator est;
  fr::HeadingEstimate e;
  timed_loop(state, "ours_" + type, [&] {
    (void)det->detect(f.current, cur);
    auto r = est.estimate(map, cur, 640.0);
    if (r.ok()) e = *r;
    benchmark::DoNotOptimize(e);
  });
  state.counters["offset_px"] = e.offset_px;
  state.counters["inliers"] = e.inliers;
  state.counters["features"] = static_cast<double>(cur.keypoints.size());
  if (cycle_ms().count("plain") != 0) state.counters["plain_over_ours"] = cycle_ms()["plain"] / cycle_ms()["ours_" + type];
}

// The temporal filter of the vote histograms (issue 36, SegmentReplayParams::temporal_decay):
// star_brief + estimate + HeadingHistogramFilter::update per frame (decay 0.7, a small odometric
// shift each frame). filter_over_single = this cycle / ours_star_brief.
void BM_ours_filtered(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto& f = frames();
  const auto det = bench_detector(state, "star_brief");
  visnav::Features map, cur;
  if (!det || !warm_detect(state, *det, f.reference, map)) return;
  fr::HeadingEstimator est;
  fr::HeadingFilterParams fp;
  fp.decay = 0.7;
  fr::HeadingHistogramFilter filter(fp, est.params().bin_width_px, est.params().bin_count);
  fr::FilteredHeading filtered;
  double shift_px = 0.5;
  timed_loop(state, "ours_star_brief_filtered", [&] {
    (void)det->detect(f.current, cur);
    auto r = est.estimate(map, cur, 640.0);
    if (r.ok()) {
      auto u = filter.update(est.last_histogram(), shift_px);
      if (u.ok()) filtered = *u;
    }
    shift_px = -shift_px;
    benchmark::DoNotOptimize(filtered);
  });
  state.counters["offset_px"] = filtered.offset_px;
  state.counters["votes"] = filtered.votes;
  if (cycle_ms().count("ours_star_brief") != 0)
    state.counters["filter_over_single"] = cycle_ms()["ours_star_brief_filtered"] / cycle_ms()["ours_star_brief"];
  if (cycle_ms().count("plain") != 0)
    state.counters["plain_over_ours"] = cycle_ms()["plain"] / cycle_ms()["ours_star_brief_filtered"];
}

// Multi-experience maps (issue 13 part 3): star_brief + ExperienceSelector over 3 experiences of
// the place: the matching reference and two of other appearance (the photo blurred and darkened,
// and mirrored). `recheck_below` 0.5 (the default): the last winner is confident, one experience
// is matched per frame; 1.0: every experience is matched every frame (the worst case, e.g. a
// place where none matches well). experiences_over_single = this cycle / ours_star_brief.
void BM_experiences(benchmark::State& state, double recheck_below) {
  cv::setNumThreads(1);
  const auto& f = frames();
  const auto det = bench_detector(state, "star_brief");
  if (!det) return;
  cv::Mat dark, mirrored;
  cv::GaussianBlur(f.reference, dark, cv::Size(0, 0), 1.5);
  dark.convertTo(dark, -1, 0.6, 10.0);
  cv::flip(f.reference, mirrored, 1);
  std::vector<visnav::Features> experiences(3);
  const cv::Mat* images[3] = {&f.reference, &dark, &mirrored};
  for (int k = 0; k < 3; ++k)
    if (!warm_detect(state, *det, *images[k], experiences[static_cast<std::size_t>(k)])) return;
  std::vector<fr::HeadingEstimator> est(3);
  std::vector<fr::HeadingEstimate> out(3);
  fr::ExperienceSelector selector(3, recheck_below);
  visnav::Features cur;
  int chosen = 0;
  double evaluations = 0.0;
  const std::string key = recheck_below < 1.0 ? "exp3_star_brief" : "exp3_all_star_brief";
  timed_loop(state, key, [&] {
    (void)det->detect(f.current, cur);
    chosen = selector.select([&](int i) {
      const auto k = static_cast<std::size_t>(i);
      auto r = est[k].estimate(experiences[k], cur, 640.0);
      out[k] = r.ok() ? *r : fr::HeadingEstimate{};
      return fr::ExperienceSelector::Score{out[k].confidence, out[k].inliers};
    });
    evaluations += selector.evaluations();
    benchmark::DoNotOptimize(chosen);
  });
  state.counters["chosen"] = chosen;
  state.counters["offset_px"] = out[static_cast<std::size_t>(chosen)].offset_px;
  state.counters["experiences_matched_per_frame"] = evaluations / static_cast<double>(state.iterations());
  if (cycle_ms().count("ours_star_brief") != 0)
    state.counters["experiences_over_single"] = cycle_ms()[key] / cycle_ms()["ours_star_brief"];
  if (cycle_ms().count("plain") != 0) state.counters["plain_over_ours"] = cycle_ms()["plain"] / cycle_ms()[key];
}
#endif

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  // Registration order = run order: the plain rows first, so the ratios can be computed.
  benchmark::RegisterBenchmark("plain/orb_bfmatcher_knn_ratio_hist41x20", BM_plain_orb_bfmatcher)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("match_vote/plain_bfmatcher", BM_match_vote_plain)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("match_vote/ours", BM_match_vote_ours)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("match_vote/ours_like_for_like_no_gate_ratio_0.7", BM_match_vote_ours_no_gate)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("ours/opencv_orb", BM_ours_opencv_orb)->Unit(benchmark::kMillisecond);
#ifdef VISNAV_HAVE_DETECTOR_CORE
  for (const auto& type : visnav::detectors::detector_type_names())
    benchmark::RegisterBenchmark(("ours/" + type).c_str(), BM_ours_detector, type)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("ours/star_brief_temporal_filter_0.7", BM_ours_filtered)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("experiences/star_brief_3_recheck_0.5", BM_experiences, 0.5)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("experiences/star_brief_3_all_every_frame", BM_experiences, 1.0)
      ->Unit(benchmark::kMillisecond);
#else
  std::fprintf(stderr, "bench_feature_replay: visnav_detector_core not built; only OpenCV ORB rows\n");
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::printf("\nsummary (thread CPU ms per frame; plain/ours ratio; targets: star_brief <= 10 ms, >= 1.5x):\n");
  const double plain = cycle_ms().count("plain") ? cycle_ms()["plain"] : 0.0;
  for (const auto& [k, ms] : cycle_ms()) {
    if (k.rfind("ours_", 0) == 0 && plain > 0.0) std::printf("  %-24s %7.2f ms   plain/ours %.2fx\n", k.c_str(), ms, plain / ms);
    else std::printf("  %-24s %7.2f ms\n", k.c_str(), ms);
  }
  return 0;
}
