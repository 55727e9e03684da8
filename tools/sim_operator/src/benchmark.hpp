// `visnav benchmark`: the experiment of `visnav experiment` over generated worlds (issue 38).
// Per world seed W (visnav_sim/generate.hpp) and per map kind and run seed S: teach the world's
// closed route with one draw of every error model, displace the robot at the start (1 m to the
// left, 10° turned), replay the loop N times with another draw; in the worlds that have an
// obstacle file (every third world seed) the obstacles stand on the route during the replays and
// the avoiding tree drives. Failures count as failures: a loop that is not completed (lost stop,
// collision, outside the success radius, not driven after an earlier stop) fails.
//
// The world seeds the defaults were chosen on are 1-20 and 1001-1020 (development); the figures
// are reported on 2001-2020 (held out, the command's default); docs/benchmark.md names them.
//
// Resumable: each run writes <out>/runs/<world>/<map>/seed<S>/result.tsv last, atomically; a run
// whose result file exists is not run again (--fresh runs everything). Runs are independent and
// executed on `jobs` threads; a run's result depends only on its world seed, map and run seed.
#pragma once

#include <string>
#include <vector>

#include "experiment.hpp"
#include "visnav/host.hpp"
#include "visnav/result.hpp"

namespace visnav::simop {

struct BenchmarkOptions {
  int worlds = 20;
  int first_world = 2001;  ///< held-out world seeds by default (docs/benchmark.md)
  int seeds = 3;
  int first_seed = 1;
  int loops = 2;
  int jobs = 0;  ///< threads; 0 = hardware concurrency
  std::vector<std::string> maps = {"hybrid", "feature"};
  std::string obstacles = "auto";  ///< generator's obstacles mode: auto (every third world), yes, no
  std::string kind = "any";        ///< generator's world kind
  double displace_m = 1.0;
  double displace_heading_deg = 10.0;
  double success_radius_m = 1.0;
  std::string config = "config/sim_experiment.yaml";
  std::vector<std::string> overrides;     ///< --set, both phases
  std::vector<std::string> replay_ports;  ///< --port Node.port=value in the replay trees
  std::string out = "out/benchmark";
  bool fresh = false;   ///< run every run again (default: resume)
  bool progress = true;
};

/// The outcome of one run as the benchmark keeps it (result.tsv).
struct BenchmarkRun {
  std::string world;  ///< gen_NNNN
  std::string world_kind;  ///< indoor | outdoor | mixed
  int world_seed = 0;
  std::string map;
  int seed = 0;
  int obstacles = 0;  ///< obstacles standing/walking on the route in the replays
  double route_length_m = 0.0;
  std::string setup_error;
  std::vector<LoopOutcome> loops;
  int collisions = 0;  ///< 1 when the replay touched something (a contact ends it), else 0
  int lost_stops = 0;
  std::string stop_reason;
  AccuracyRepeatability metrics;  ///< over the finished loops
  double wall_s = 0.0;
  bool resumed = false;  ///< read from an earlier invocation's result file

  /// Obstacle encounters: obstacles × loops the robot drove into (finished, or stopped in).
  [[nodiscard]] int encounters() const;
};

/// Why a loop failed, in the table's classes: "lost", "collision", "outside radius",
/// "not driven" (an earlier stop ended the replay), "setup", "other".
[[nodiscard]] std::string failure_class(const BenchmarkRun& run, const LoopOutcome& loop);

/// Generates the worlds, runs every (world, map, seed) not yet done, writes runs.csv, report.md
/// and benchmark.png under options.out and returns every run (world-major, then map, then seed).
/// Error: bad options, config or output folder (nothing was run).
[[nodiscard]] Result<std::vector<BenchmarkRun>> run_benchmark(const BenchmarkOptions& options);

/// The results table (markdown): per map kind and condition (without / with obstacles).
[[nodiscard]] std::string benchmark_table(const BenchmarkOptions& options, const std::vector<BenchmarkRun>& runs);

/// Entry point of the plugin command (argv[0] = "benchmark").
int benchmark_command(int argc, char** argv, HostServices& host);

}  // namespace visnav::simop
