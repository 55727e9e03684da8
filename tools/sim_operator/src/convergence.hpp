// `visnav convergence`: the straight-segment comparison of seed 000 Sec. 6.1 / Fig. 3 in the
// simulator, through the shipped primitives (real plugin loader, session, behaviour-tree nodes
// and map store, as `visnav experiment`):
//
//   1. teach: one session on the world (default straight6m) drives straight from the world's
//      start pose for `length_m` of odometry while TeachPathEdge and TeachFeatureEdge (style A
//      "segment" and style B "localmaps") record one edge each, in parallel, from the same frames;
//   2. replay: for every replay i (0-based) and every primitive a fresh session starts
//      `displacement_m` to the left (i even) or right (i odd) of the taught start, with robot and
//      camera noise seeds `first_seed + i`, and runs FollowPathEdge / ReplayFeatureEdge on that
//      primitive's edge until the node ends;
//   3. measure: every tick the simulator's ground truth is expressed in the taught segment's
//      frame (origin and heading of the teach start): x = distance along the segment from the
//      replay start, y = signed lateral offset (left +). y = a·e^(−k·x) is fitted to each replay
//      with path_following::fit_exponential_decay (NLopt least squares); k in 1/m.
//
// The navigation never sees the ground truth; it is read only for the evaluation.
// Thread-safety: run_convergence is not reentrant with respect to the out_dir it writes to;
// everything else is pure.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/host.hpp"
#include "visnav/path_following/exp_fit.hpp"
#include "visnav/result.hpp"

namespace visnav::simop {

/// Edge kinds (= primitive names) the command compares.
inline constexpr const char* kPathKind = "path_following";
inline constexpr const char* kSegmentKind = "feature_segment";
inline constexpr const char* kLocalMapsKind = "feature_localmaps";

struct ConvergenceOptions {
  std::string world = "straight6m";    ///< world name or file; must have a straight path from its start pose
  double length_m = 5.6;               ///< odometric length of the taught segment (seed 000: 5.6 m)
  double displacement_m = 0.5;         ///< lateral displacement of each replay start, m (> 0)
  int replays = 5;                     ///< replays per primitive; signs alternate +, −, +, ...
  int first_seed = 1;                  ///< robot/camera noise seed of replay 0 (replay i: first_seed + i)
  double speed_mps = 0.4;              ///< teach speed and replay speed limit of every primitive
  double camera_noise_std = 2.0;       ///< sensor noise of the simulated camera (grey levels), seeded per replay
  std::vector<std::string> primitives = {kPathKind, kSegmentKind, kLocalMapsKind};
  std::string config = "config/sim_experiment.yaml";  ///< run configuration (robot sim, camera sim, detector, nodes)
  std::vector<std::string> overrides;  ///< `key=value` config overrides applied to every session
  std::string out_dir = "out/convergence";  ///< map/, trees/ (always); CSVs and PNG by write_outputs
  std::vector<std::string> plugin_dirs;     ///< extra plugin search directories (tests)
  bool use_default_plugin_path = true;
  bool progress = false;               ///< progress line on stderr

  /// Errors: non-positive length/displacement/speed, replays outside [1, 100], negative noise,
  /// an empty or unknown primitive, an empty out_dir.
  [[nodiscard]] Status validate() const;
};

/// One replay of one primitive.
struct ReplayTrace {
  std::string primitive;           ///< edge kind
  int replay = 0;                  ///< 0-based
  int seed = 0;
  double start_offset_m = 0.0;     ///< lateral offset at the replay start (ground truth)
  std::vector<double> distance_m;  ///< x: along the taught segment from the replay start
  std::vector<double> offset_m;    ///< y: signed lateral offset from the taught line (left +)
  bool completed = false;          ///< the replay node returned SUCCESS (edge length reached)
  std::string failure;             ///< why it did not complete (empty when completed)
  std::optional<path_following::ExpDecayFit> fit;
  std::string fit_error;           ///< why there is no fit
  [[nodiscard]] double final_offset_m() const { return offset_m.empty() ? 0.0 : offset_m.back(); }
};

/// k over the fitted replays of one primitive.
struct PrimitiveSummary {
  std::string primitive;
  int replays = 0;
  int fitted = 0;
  double mean_k_per_m = 0.0;
  double sd_k_per_m = 0.0;         ///< sample standard deviation (0 with fewer than 2 fits)
  double mean_abs_final_offset_m = 0.0;
};

struct ConvergenceReport {
  std::string world;
  double taught_length_m = 0.0;    ///< odometric length stored on the edges
  std::vector<ReplayTrace> traces; ///< replay-major: replay 0 of every primitive, then replay 1, ...
  std::vector<PrimitiveSummary> summary;  ///< in options.primitives order
  double wall_s = 0.0;
  [[nodiscard]] const PrimitiveSummary* find(const std::string& primitive) const;
};

/// Mean and sample standard deviation of the fitted k per primitive (in `order`).
[[nodiscard]] std::vector<PrimitiveSummary> summarise(const std::vector<ReplayTrace>& traces,
                                                      const std::vector<std::string>& order);

/// Teaches and replays as described in the file comment. Errors: bad options, the config or a
/// session failing to build, teaching failing. A replay that fails is reported in its trace.
[[nodiscard]] Result<ConvergenceReport> run_convergence(const ConvergenceOptions& options);

/// Offset against distance per primitive, one panel each side by side (as seed 000 Fig. 3),
/// with the fitted curves dashed. BGR, 8-bit.
[[nodiscard]] cv::Mat draw_convergence(const ConvergenceReport& report);

/// Markdown table: per replay start offset, a, k, rms, final offset; then mean ± sd of k.
[[nodiscard]] std::string convergence_table(const ConvergenceReport& report);

/// Writes samples.csv, fits.csv, convergence.png and report.md into `out_dir`.
[[nodiscard]] Status write_convergence_outputs(const ConvergenceReport& report, const ConvergenceOptions& options);

/// Entry point of the plugin command (argv[0] = "convergence").
int convergence_command(int argc, char** argv, HostServices& host);

}  // namespace visnav::simop
