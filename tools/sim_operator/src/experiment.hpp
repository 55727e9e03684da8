// `visnav experiment`: the seed 000 Sec. 6.3/6.4 experiment in the simulator, repeated over
// independent random runs. Per map style and per seed: teach a closed route from its script
// with one draw of the simulator's error models, displace the robot (lateral to the first
// replayed edge, plus a heading error), replay the loop N times with another draw, and measure
// each loop's end-position error against ground truth. A loop counts as completed only when
// the robot finished it, within success_radius_m of the taught end and without a collision;
// a replay that stops (lost, camera frozen, collision) fails that loop and every loop after it.
// The table gives per style: loops completed / attempted, ε_acc and ε_rep (seed 000 eq. 18) as
// mean ± sd and worst over seeds, along- and cross-track RMS, collisions, lost stops, wall time.
//
// Runs are independent (one Session each, robot named per run) and executed on `jobs` threads;
// a run's result depends only on its seed, never on scheduling.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/types.hpp"

namespace visnav::simop {

/// ε_acc = sqrt(mean ||x_i − x_f||²), ε_rep = sqrt(mean ||x_i − μ||²), μ = mean x_i
/// (seed 000 eq. 18). `ends` are the loop end positions, `taught_end` x_f.
struct AccuracyRepeatability {
  double accuracy_m = 0.0;
  double repeatability_m = 0.0;
};
[[nodiscard]] AccuracyRepeatability accuracy_repeatability(const std::vector<cv::Point2d>& ends,
                                                           const cv::Point2d& taught_end);

/// Mean, sample standard deviation and largest value of a list (all 0 for an empty list).
struct Spread {
  double mean = 0.0;
  double sd = 0.0;
  double worst = 0.0;
  int count = 0;
};
[[nodiscard]] Spread spread(const std::vector<double>& values);

struct ExperimentOptions {
  std::string world = "campus";
  std::string route;                       ///< default: the world's name
  double displace_m = 1.0;                 ///< lateral (left +) to the first replayed edge
  double displace_heading_deg = 10.0;      ///< heading error at the replay start (CCW +)
  int loops = 5;
  int seeds = 5;
  int first_seed = 1;
  int jobs = 0;                            ///< threads; 0 = hardware concurrency
  double success_radius_m = 1.0;
  bool ideal = false;                      ///< all error models off (regression runs only)
  std::vector<std::string> maps = {"hybrid", "feature"};
  std::string config = "config/sim_experiment.yaml";
  std::string out = "out/experiment";
  std::vector<std::string> overrides;          ///< --set, both phases
  std::vector<std::string> teach_overrides;    ///< --teach-set and --teach-appearance
  std::vector<std::string> replay_overrides;   ///< --replay-set and --replay-appearance
  std::vector<std::string> replay_ports;       ///< --port Node.port=value: set in the replay trees (not the teach's)
  /// --replay-tree FILE: the measured replay's tree instead of trees/patrol_loop.xml (blackboard
  /// entries start and loops; the camera mount comes from the replay camera's params); empty = that
  /// one, or trees/patrol_loop_avoiding.xml when obstacles are placed (--obstacles).
  std::string replay_tree;
  bool obstacles = false;  ///< --obstacles given (the avoiding tree by default)
  std::string log_level = "warn";  ///< --log-level: lowest level written to each run's run.log
  std::string teach_appearance = "same";
  std::string replay_appearance = "same";
  /// Multi-experience maps (issue 13): patrol loops driven after teaching with learn_experiences
  /// on, in the replay conditions (trees/patrol_loop_learning.xml), before the measured replay;
  /// not measured. 0 = none.
  int learn_loops = 0;
  /// Learning loops: how far a frame is learned without a confident match and the lost policy's
  /// blind distance (patrol_loop_learning.xml's learn_hold_m / learn_max_blind_m); 0 = the
  /// replay's defaults (1 m / 5 m).
  double learn_blind_m = 0.0;
  /// Multi-experience maps by a supervised drive (issue 13): after the teach, the scripted
  /// operator drives the route again under this appearance (its own draw of the error models,
  /// its own session) with the teach tree into <run>/experience_drive/map, and every feature edge
  /// it taught is added to the taught map's edge of the same id as an appearance experience
  /// (feature_replay's add_drive_experiences). Empty = none.
  std::string experience_teach;
  bool progress = true;                    ///< progress line on stderr
  /// Called after every replay tick with the simulator, the robot and the odometric distance
  /// driven since the replay started: disturbances for tests (kidnapping, outside commands).
  /// Runs on the run's thread; must not keep the references.
  std::function<void(SimulationControl& sim, Robot& robot, double replay_distance_m)> replay_hook;
};

/// `--maps` text: comma-separated map kinds, each hybrid, feature or path. Error names the bad one.
[[nodiscard]] Result<std::vector<std::string>> parse_map_kinds(const std::string& text);
/// `--displace M[,DEG]`: metres to the left in [-5, 5], degrees in [-90, 90] (unchanged when absent).
[[nodiscard]] Status parse_displacement(const std::string& text, double& lateral_m, double& heading_deg);

/// Overrides of a named appearance (camera params): same, winter, autumn, dusk, low_sun,
/// overcast. Error: unknown name (lists the known ones).
[[nodiscard]] Result<std::vector<std::string>> appearance_overrides(const std::string& name);
/// Overrides that switch every error model of config/sim_experiment.yaml off (--ideal).
[[nodiscard]] std::vector<std::string> ideal_overrides();

/// One replayed loop.
struct LoopOutcome {
  int loop = 0;               ///< 1-based
  bool finished = false;      ///< the route was driven to its end
  bool completed = false;     ///< finished within the radius, no collision
  cv::Point2d end;            ///< ground truth where the loop ended (or where the robot stopped)
  double error_m = 0.0;
  double along_m = 0.0;       ///< in the taught end heading's frame, forward +
  double cross_m = 0.0;       ///< left +
  std::string failure;        ///< why it did not complete (empty when completed)
};

/// One teach + replay run of one map style with one seed.
struct ExperimentRun {
  std::string style;
  int seed = 0;
  std::string setup_error;    ///< the run could not be set up or taught (no loops driven)
  std::vector<LoopOutcome> loops;  ///< one per attempted loop
  std::vector<SimCollision> collisions;
  int lost_stops = 0;         ///< replays stopped by lost / frozen-camera detection
  std::string stop_reason;    ///< why the replay ended early (empty: all loops driven)
  cv::Point2d replay_start;   ///< ground truth where the replay started (after the displacement)
  cv::Point2d taught_end;     ///< ground truth where teaching ended
  double replay_odometry_m = 0.0;  ///< odometric distance driven by the replay
  double coast_after_stop_m = 0.0;  ///< ground truth moved in the 2 s after the replay run ended
  AccuracyRepeatability metrics;  ///< over the finished loops
  double wall_s = 0.0;
  double route_length_m = 0.0;
  std::uint64_t map_bytes = 0;
  double map_length_m = 0.0;
  std::string teach_errors;   ///< the sim robot's drawn run errors, for the report
  std::string replay_errors;
  int learn_loops_driven = 0;  ///< learning loops completed before the measured replay (learn_loops)
  int experiences_added = 0;   ///< feature edges given a supervised drive's experience (experience_teach)
  int experience_edges = 0;    ///< feature edges of the taught map (experience_teach)
};

/// Runs every (style, seed) of `options`, writes the CSVs, pictures, report.md and
/// summary.json under options.out, and returns the outcomes (style-major, seed-minor).
/// Error: bad world/route/config (nothing was run).
[[nodiscard]] Result<std::vector<ExperimentRun>> run_experiment(const ExperimentOptions& options);

/// One teach + replay run of `style` with `seed` on options.world/options.route, its files in
/// `dir` (run.log, loops.csv, edges.csv, trajectories.png); `progress(done_m, total_m)` is called
/// from the run's thread after every replay tick (may be empty). What run_experiment runs per job
/// (the benchmark runs these across generated worlds). Thread-safe for distinct `dir`s.
/// Error: bad world/route (nothing was run); a run that fails later reports it in setup_error.
[[nodiscard]] Result<ExperimentRun> run_experiment_job(const ExperimentOptions& options, const std::string& style, int seed,
                                                       const std::string& dir,
                                                       const std::function<void(double, double)>& progress = {});

/// The results table (markdown) of run_experiment's outcomes.
[[nodiscard]] std::string experiment_table(const ExperimentOptions& options, const std::vector<ExperimentRun>& runs);

/// Entry point of the plugin command (argv[0] = "experiment").
int experiment_command(int argc, char** argv, HostServices& host);

}  // namespace visnav::simop
