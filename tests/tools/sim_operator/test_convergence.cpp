// `visnav convergence` (seed 000 Fig. 3 as numbers), reduced case through the real loader, the
// real sim robot/camera, star_brief, and the shipped nodes TeachPathEdge/FollowPathEdge and
// TeachFeatureEdge/ReplayFeatureEdge (style A): straight6m, 5.6 m taught, one replay per primitive
// from 0.5 m to the left. Both offsets decay (k > 0) and the path follower converges faster
// than the feature-based replay — the paper's claim for an outdoor path with distant scenery.
// Plus the pure parts: option validation, the per-primitive summary, the outputs.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "convergence.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::simop;

namespace {

fs::path temp_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("visnav_convergence_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

ReplayTrace trace(const std::string& primitive, double k, double final_offset_m) {
  ReplayTrace t;
  t.primitive = primitive;
  t.distance_m = {0.0, 1.0};
  t.offset_m = {0.5, final_offset_m};
  t.completed = true;
  t.fit = path_following::ExpDecayFit{0.5, k, 0.01};
  return t;
}

}  // namespace

TEST(Convergence, OptionsAreValidated) {
  ConvergenceOptions o;
  EXPECT_TRUE(o.validate().ok());
  auto bad = [](auto change) {
    ConvergenceOptions c;
    change(c);
    return !c.validate().ok();
  };
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.length_m = 0.0; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.displacement_m = -0.5; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.replays = 0; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.speed_mps = 0.0; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.camera_noise_std = -1.0; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.primitives = {}; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.primitives = {"visual_memory"}; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.primitives = {kPathKind, kPathKind}; }));
  EXPECT_TRUE(bad([](ConvergenceOptions& c) { c.out_dir.clear(); }));
}

TEST(Convergence, SummaryIsMeanAndSampleSdOfTheFittedK) {
  std::vector<ReplayTrace> traces = {trace(kPathKind, 0.4, 0.02), trace(kSegmentKind, 0.1, 0.3),
                                     trace(kPathKind, 0.6, -0.04), trace(kSegmentKind, 0.2, -0.2)};
  traces.push_back(trace(kPathKind, 0.0, 0.1));
  traces.back().fit.reset();  // a replay without a fit counts as a replay, not in k
  const auto s = summarise(traces, {kPathKind, kSegmentKind, kLocalMapsKind});
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].primitive, kPathKind);
  EXPECT_EQ(s[0].replays, 3);
  EXPECT_EQ(s[0].fitted, 2);
  EXPECT_NEAR(s[0].mean_k_per_m, 0.5, 1e-12);
  EXPECT_NEAR(s[0].sd_k_per_m, std::sqrt(0.02), 1e-12);  // sample sd of {0.4, 0.6}
  EXPECT_NEAR(s[0].mean_abs_final_offset_m, (0.02 + 0.04 + 0.1) / 3.0, 1e-12);
  EXPECT_NEAR(s[1].mean_k_per_m, 0.15, 1e-12);
  EXPECT_EQ(s[2].replays, 0);
  EXPECT_EQ(s[2].fitted, 0);
}

TEST(Convergence, PathFollowingConvergesFasterThanFeatureReplayOnTheStraightGravelPath) {
  const fs::path dir = temp_dir("reduced");
  ConvergenceOptions o;
  o.world = "straight6m";
  o.replays = 1;
  o.primitives = {kPathKind, kSegmentKind};
  o.out_dir = dir.string();
  o.plugin_dirs = {VISNAV_TEST_PLUGIN_DIR};
  o.use_default_plugin_path = false;
  auto report = run_convergence(o);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->traces.size(), 2u);
  EXPECT_NEAR(report->taught_length_m, o.length_m, 0.1);
  for (const auto& t : report->traces) {
    ASSERT_TRUE(t.completed) << t.primitive << ": " << t.failure;
    ASSERT_TRUE(t.fit.has_value()) << t.primitive << ": " << t.fit_error;
    std::printf("%s: start %+.3f m, a %+.3f m, k %.3f 1/m, rms %.3f m, final offset %+.3f m after %.2f m\n",
                t.primitive.c_str(), t.start_offset_m, t.fit->a, t.fit->k, t.fit->rms, t.final_offset_m(),
                t.distance_m.back());
    EXPECT_NEAR(t.start_offset_m, 0.5, 0.02) << t.primitive;  // displaced to the left
    EXPECT_GT(t.distance_m.back(), 0.9 * o.length_m / 1.03 - 0.3) << t.primitive;  // drove the segment (3 % odometry scale error)
    EXPECT_GT(t.fit->k, 0.0) << t.primitive << ": the offset must decay";
    EXPECT_LT(std::abs(t.final_offset_m()), t.start_offset_m) << t.primitive;
  }
  const ReplayTrace& path = report->traces[0];
  const ReplayTrace& feature = report->traces[1];
  ASSERT_EQ(path.primitive, kPathKind);
  EXPECT_GT(path.fit->k, feature.fit->k) << "path following must converge faster (seed 000 Sec. 6.1)";
  EXPECT_LT(std::abs(path.final_offset_m()), 0.15);

  ASSERT_TRUE(write_convergence_outputs(*report, o).ok());
  for (const char* f : {"samples.csv", "fits.csv", "convergence.png", "report.md"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  std::ifstream fits(dir / "fits.csv");
  std::string header, line;
  std::getline(fits, header);
  int rows = 0;
  while (std::getline(fits, line)) ++rows;
  EXPECT_EQ(rows, 2);
  fs::remove_all(dir);
}
