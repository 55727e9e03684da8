// Per-frame cost of the IPT obstacle detection (issue 16: "IPT classification + polar map
// ≤ 10 ms per 320×240 frame on 2 cores"). OpenCV limited to 2 threads (cv::setNumThreads(2)).
// Input: pairs rendered by the simulator 2 cm apart past the obstacles of obstacle_course.
//  * BM_ClassifyAndPolarMap — classification of the pair's tracked inliers, reduced Canny,
//    contact points and one navigation-filter decision (the IPT part; tracks precomputed);
//  * BM_FullPipeline — the whole cycle: Shi-Tomasi + pyramidal LK (250 corners) + RANSAC on F
//    (500 iterations) + the above.
// Counter frame_ms: wall time per frame.
#include <benchmark/benchmark.h>

#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "visnav/ipt_obstacles/motion_watch.hpp"
#include "visnav/ipt_obstacles/pipeline.hpp"
#include "visnav/ipt_obstacles/polar_map.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace vi = visnav::ipt;
namespace vs = visnav::sim;

namespace {

struct Pair {
  cv::Mat a, b;
  visnav::Pose2D pa, pb;
  std::vector<cv::Point2f> ta, tb;  // RANSAC inlier tracks
};

struct Data {
  vi::IptCamera camera;
  std::vector<Pair> pairs;
};

const Data& data() {
  static const Data d = [] {
    Data out;
    auto world = vs::load_world_cached(*vs::resolve_world_path("obstacle_course"));
    vs::CameraModel model;
    model.hfov_deg = 65.5;
    model.height_m = 0.43;
    model.pitch_down_deg = 9.0;
    vs::Renderer renderer(*world, model);
    out.camera.fx_px = out.camera.fy_px = model.fx();
    out.camera.cx_px = model.cx();
    out.camera.cy_px = model.cy();
    out.camera.height_m = 0.43;
    out.camera.pitch_rad = -9.0 * CV_PI / 180.0;
    for (const double x : {0.5, 1.5, 2.5, 5.0, 9.0, 12.0, 15.0, 17.0}) {
      Pair p;
      p.pa = {x, x > 8.5 ? -1.7 : 0.0, 0.0};
      p.pb = {x + 0.02, p.pa.y_m, 0.0};
      cv::Mat bgr;
      renderer.render(p.pa, bgr);
      cv::cvtColor(bgr, p.a, cv::COLOR_BGR2GRAY);
      renderer.render(p.pb, bgr);
      cv::cvtColor(bgr, p.b, cv::COLOR_BGR2GRAY);
      std::vector<cv::Point2f> c0, c1;
      std::vector<std::uint8_t> st, in;
      std::vector<float> err;
      cv::goodFeaturesToTrack(p.a, c0, 250, 0.01, 5.0);
      cv::calcOpticalFlowPyrLK(p.a, p.b, c0, c1, st, err, cv::Size(15, 15), 3);
      std::vector<cv::Point2f> a, b;
      for (std::size_t i = 0; i < c0.size(); ++i)
        if (st[i] != 0) {
          a.push_back(c0[i]);
          b.push_back(c1[i]);
        }
      cv::findFundamentalMat(a, b, cv::FM_RANSAC, 1.0, 0.99, 500, in);
      for (std::size_t i = 0; i < a.size(); ++i)
        if (in.empty() || in[i] != 0) {
          p.ta.push_back(a[i]);
          p.tb.push_back(b[i]);
        }
      out.pairs.push_back(std::move(p));
    }
    return out;
  }();
  return d;
}

void BM_ClassifyAndPolarMap(benchmark::State& state) {
  cv::setNumThreads(2);
  const Data& d = data();
  const vi::ClassifierParams classifier;
  const vi::ProfileParams profiles;
  cv::Mat edges;
  vi::EdgeScratch scratch;
  std::size_t i = 0;
  for (auto _ : state) {
    const Pair& p = d.pairs[i++ % d.pairs.size()];
    auto features = vi::classify_features(d.camera, vi::lens_pose(d.camera, p.pa), vi::lens_pose(d.camera, p.pb), p.ta,
                                          p.tb, classifier);
    vi::reduced_canny(p.b, profiles, edges, scratch);
    const auto contacts = vi::contact_points(edges, *features, d.camera, p.pb, profiles);
    vi::NavigationFilter filter{vi::PolarMapParams{}};
    std::vector<cv::Point2d> pts;
    for (const auto& c : contacts) pts.push_back(c.ground_m);
    filter.add_points(pts);
    benchmark::DoNotOptimize(filter.decide(p.pb, {p.pb.x_m + 5.0, p.pb.y_m}));
  }
  state.counters["frame_ms"] = benchmark::Counter(static_cast<double>(state.iterations()) * 1e-3,
                                                  benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ClassifyAndPolarMap)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_FullPipeline(benchmark::State& state) {
  cv::setNumThreads(2);
  const Data& d = data();
  auto pipeline = vi::ObstaclePipeline::create(d.camera, vi::PipelineParams{}, vi::ClassifierParams{}, vi::ProfileParams{});
  vi::NavigationFilter filter{vi::PolarMapParams{}};
  std::size_t i = 0;
  for (auto _ : state) {
    const Pair& p = d.pairs[i++ % d.pairs.size()];
    state.PauseTiming();
    pipeline->restart();
    (void)pipeline->process(p.a, p.pa);
    state.ResumeTiming();
    auto r = pipeline->process(p.b, p.pb);
    std::vector<cv::Point2d> pts;
    for (const auto& c : (*r)->contacts) pts.push_back(c.ground_m);
    filter.reset();
    filter.add_points(pts);
    benchmark::DoNotOptimize(filter.decide(p.pb, {p.pb.x_m + 5.0, p.pb.y_m}));
  }
  state.counters["frame_ms"] = benchmark::Counter(static_cast<double>(state.iterations()) * 1e-3,
                                                  benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_FullPipeline)->Unit(benchmark::kMillisecond)->UseRealTime();

// The near-corridor frame difference ReplayAvoiding runs on every frame while driving (issue 16,
// moving obstacles): blur, ground-plane warp of the previous frame for the odometry motion and the
// count; the worst case, every scale of the motion searched (5 warps), is what ReplayAvoiding
// pays when something is there. Pairs 2 cm apart as above.
void BM_MotionWatchDriving(benchmark::State& state) {
  const Data& d = data();
  vi::MotionWatchParams params;
  params.near_m = 0.8;
  params.far_m = 2.0;
  params.half_width_m = 1.2;
  params.min_changed_px = 1;  // hardly ever "still": every scale of the motion is searched
  auto made = vi::MotionWatch::create(d.camera, params);
  if (!made) {
    state.SkipWithError(made.error().message.c_str());
    return;
  }
  vi::MotionWatch watch = std::move(*made);
  std::size_t i = 0;
  for (auto _ : state) {
    const Pair& p = d.pairs[i++ % d.pairs.size()];
    watch.reset();
    (void)watch.observe(p.a, visnav::Pose2D{});
    auto n = watch.observe(p.b, visnav::Pose2D{0.02, 0.0, 0.0});
    benchmark::DoNotOptimize(n);
  }
}
BENCHMARK(BM_MotionWatchDriving)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
