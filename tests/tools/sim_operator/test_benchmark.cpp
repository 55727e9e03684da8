// `visnav benchmark` (issue 38) on a 3-world smoke version, closed loop through the real loader,
// plugins and trees with the realistic error models of config/sim_experiment.yaml on: generated
// development worlds 1, 2 and 4 (mixed, indoor with a corridor, indoor), hybrid maps, one seed,
// one loop. Every loop completes; a second invocation resumes (runs nothing, same table); a
// damaged result file is run again; failures are counted by reason.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "benchmark.hpp"

namespace fs = std::filesystem;
using namespace visnav::simop;

namespace {

BenchmarkOptions smoke(const std::string& name) {
  BenchmarkOptions o;
  o.worlds = 1;
  o.seeds = 1;
  o.loops = 1;
  o.jobs = 2;
  o.maps = {"hybrid"};
  o.obstacles = "no";
  o.progress = false;
  o.config = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/sim_experiment.yaml";
  o.out = (fs::temp_directory_path() / ("visnav_benchmark_" + std::to_string(::getpid()) + "_" + name)).string();
  return o;
}

}  // namespace

TEST(Benchmark, ThreeGeneratedWorldsCompleteAndASecondInvocationResumes) {
  std::vector<BenchmarkRun> all;
  BenchmarkOptions o = smoke("three");
  fs::remove_all(o.out);
  for (int world : {1, 2, 4}) {  // one world per invocation: seeds 1, 2 and 4 (3 has obstacles)
    o.first_world = world;
    auto runs = run_benchmark(o);
    ASSERT_TRUE(runs) << runs.error().message;
    ASSERT_EQ(runs->size(), 1u);
    const BenchmarkRun& r = runs->front();
    EXPECT_EQ(r.setup_error, "") << r.world;
    ASSERT_EQ(r.loops.size(), 1u);
    EXPECT_TRUE(r.loops[0].completed) << r.world << " (" << r.world_kind << "): " << r.loops[0].failure;
    EXPECT_EQ(r.collisions, 0) << r.world;
    EXPECT_LT(r.metrics.accuracy_m, 0.3) << r.world;
    EXPECT_FALSE(r.resumed);
    all.push_back(r);
    EXPECT_TRUE(fs::exists(fs::path(o.out) / "worlds" / (r.world + "_top.png")));
    EXPECT_TRUE(fs::exists(fs::path(o.out) / "report.md"));
  }
  // resume: nothing is run again, the outcome is read back
  o.first_world = 2;
  auto again = run_benchmark(o);
  ASSERT_TRUE(again) << again.error().message;
  ASSERT_EQ(again->size(), 1u);
  EXPECT_TRUE(again->front().resumed);
  EXPECT_EQ(again->front().loops[0].completed, all[1].loops[0].completed);
  EXPECT_NEAR(again->front().metrics.accuracy_m, all[1].metrics.accuracy_m, 1e-9);
  // a damaged result file is not trusted: the run is run again
  const fs::path file = fs::path(o.out) / "runs" / "gen_0002" / "hybrid" / "seed1" / "result.tsv";
  ASSERT_TRUE(fs::exists(file));
  std::ofstream(file) << "format\tsomething else\n";
  auto rerun = run_benchmark(o);
  ASSERT_TRUE(rerun) << rerun.error().message;
  EXPECT_FALSE(rerun->front().resumed);
  EXPECT_NEAR(rerun->front().metrics.accuracy_m, all[1].metrics.accuracy_m, 1e-9) << "a run depends only on its seeds";
  // the table counts every loop
  const std::string table = benchmark_table(o, all);
  EXPECT_NE(table.find("3/3 (100.0 %)"), std::string::npos) << table;
  fs::remove_all(o.out);
}

TEST(Benchmark, FailedLoopsAreCountedByReason) {
  BenchmarkRun r;
  r.map = "hybrid";
  r.obstacles = 2;
  LoopOutcome stopped;
  stopped.loop = 1;
  stopped.failure = "collision with 'route_obstacle_1' at (1, 2)";
  LoopOutcome after;
  after.loop = 2;
  after.failure = "not driven: the replay stopped in loop 1";
  r.loops = {stopped, after};
  r.collisions = 1;
  EXPECT_EQ(failure_class(r, r.loops[0]), "collision");
  EXPECT_EQ(failure_class(r, r.loops[1]), "not driven");
  EXPECT_EQ(r.encounters(), 2);  // two obstacles, stopped in the first loop
  LoopOutcome outside;
  outside.finished = true;
  outside.failure = "ended 1.20 m from the taught end (radius 1.00 m)";
  BenchmarkRun lost = r;
  lost.collisions = 0;
  lost.lost_stops = 1;
  lost.loops = {outside, LoopOutcome{2, false, false, {}, 0, 0, 0, "lost: no confident match for 5.0 m"}};
  EXPECT_EQ(failure_class(lost, lost.loops[0]), "outside radius");
  EXPECT_EQ(failure_class(lost, lost.loops[1]), "lost");
  BenchmarkOptions o;
  o.maps = {"hybrid"};
  const std::string table = benchmark_table(o, {r, lost});
  EXPECT_NE(table.find("0/4 (0.0 %)"), std::string::npos) << table;
  EXPECT_NE(table.find("collision 1"), std::string::npos) << table;
  EXPECT_NE(table.find("lost 1"), std::string::npos) << table;
  EXPECT_NE(table.find("1 / 6"), std::string::npos) << table;  // collisions / encounters: 2 obstacles x (1 + 2) loops driven into
}
