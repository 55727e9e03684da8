// Bounded derivative-free tuning of primitive parameters (`visnav tune`).
//
// The objective of one parameter vector is ε_acc + λ·ε_rep (m) over simulated replays plus a
// penalty for every failed loop; the command gets it by running `visnav experiment` as a child
// process and reading its summary.json (objective_from_summary). Each evaluation costs minutes,
// is noisy (frame timing, loop failures are discrete jumps) and there are few parameters
// (2–6), so the optimiser is NLopt's Sbplx (Rowan's Subplex: Nelder–Mead on subspaces) by
// default: it honours bounds, needs no gradient, and — unlike BOBYQA, which fits a quadratic
// model through every point — a single outlying value (a failed loop) does not distort a model
// for the rest of the run. BOBYQA, COBYLA and Nelder–Mead remain selectable.
//
// Resuming: NLopt's derivative-free algorithms are deterministic given the objective values, so a
// run replays from a cache of earlier evaluations (keyed by the exact parameter vector) and calls
// the real objective only for vectors not seen before.
//
// Pure over std types; the objective callback does the I/O. Not thread-safe (one run per call).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::stability {

/// One tuned parameter: a config override key (`--set key=value`) and its bounds.
struct TuneParam {
  std::string key;
  double lo_value = 0.0;
  double hi_value = 1.0;
  double start_value = 0.5;  ///< start point (default: middle of the bounds)
};

/// Parses "key=lo:hi[:start],key=lo:hi,..." (bounds are required: the search is bounded).
/// Errors name the item and what is wrong ("feature.gain=2:1: lower bound 2 above upper 1").
[[nodiscard]] Result<std::vector<TuneParam>> parse_tune_params(std::string_view list);

enum class TuneAlgorithm { sbplx, bobyqa, cobyla, neldermead };
[[nodiscard]] Result<TuneAlgorithm> parse_tune_algorithm(std::string_view name);
[[nodiscard]] const char* to_string(TuneAlgorithm a);

struct TuneOptions {
  TuneAlgorithm algorithm = TuneAlgorithm::sbplx;
  int max_evals = 40;                ///< objective evaluations, ≥ 1
  double xtol_rel = 1e-3;            ///< stop when a step changes every parameter by less than this share
  double ftol_abs = 1e-4;            ///< stop when the objective improves by less than this (m)
  double initial_step_share = 0.25;  ///< first step as a share of each parameter's range, (0, 1]
  [[nodiscard]] Status validate() const;
};

struct Evaluation {
  int index = 0;               ///< 1-based order of the call
  std::vector<double> x;
  double objective = 0.0;
  bool cached = false;         ///< taken from the cache (a resumed run)
};

struct TuneResult {
  std::vector<double> best_x;
  double best_objective = 0.0;
  std::vector<Evaluation> history;
  std::string stop_reason;
};

/// Objective of a parameter vector (smaller is better). An error aborts the run (use a penalty
/// value for a failed experiment instead).
using TuneObjective = std::function<Result<double>(const std::vector<double>& x, int index)>;

/// Key of a parameter vector in the evaluation cache (exact: 17 significant digits per value).
[[nodiscard]] std::string cache_key(const std::vector<double>& x);

/// Minimises `objective` over the box of `params`. `cache` (may be null) maps cache_key(x) to
/// known values; new values are added to it. `on_eval` is called after each evaluation.
[[nodiscard]] Result<TuneResult> tune(const std::vector<TuneParam>& params, const TuneOptions& options,
                                      const TuneObjective& objective, std::map<std::string, double>* cache = nullptr,
                                      const std::function<void(const Evaluation&)>& on_eval = {});

/// How a summary.json becomes one number.
struct ObjectiveWeights {
  double lambda = 1.0;              ///< weight of ε_rep
  double failed_loop_penalty_m = 5.0;  ///< added per share of failed loops (all failed: + this)
  std::string style;                ///< map style to score ("feature", "hybrid"); empty = mean over all
  [[nodiscard]] Status validate() const;
};

struct ObjectiveBreakdown {
  double objective = 0.0;
  double eps_acc_m = 0.0;
  double eps_rep_m = 0.0;
  double failed_share = 0.0;  ///< failed loops / attempted (collisions count as failed)
};

/// One map style of an experiment's summary.json. Means/sds/worsts are NaN when absent or null
/// (e.g. nothing completed).
struct StyleSummary {
  std::string style;
  double attempted = 0.0, completed = 0.0, collisions = 0.0, lost = 0.0;
  double eps_acc_mean_m = 0.0, eps_acc_sd_m = 0.0, eps_acc_worst_m = 0.0;
  double eps_rep_mean_m = 0.0, eps_rep_sd_m = 0.0, eps_rep_worst_m = 0.0;
};

/// Parses summary.json (format below). Errors: not JSON, no "styles" list, a style without
/// "attempted"/"completed", a value of the wrong type.
[[nodiscard]] Result<std::vector<StyleSummary>> parse_summary(const std::string& json_text);

/// Scores the text of an experiment's summary.json:
///   {"styles":[{"style":"hybrid","attempted":25,"completed":24,"eps_acc_m":{"mean":..},
///               "eps_rep_m":{"mean":..},"collisions":0,"lost":0}, ...]}
/// objective = ε_acc.mean + λ·ε_rep.mean + penalty × failed/attempted, failed = attempted −
/// completed + collisions (at most attempted). A style with no completed loop scores ε = 0 plus
/// the full penalty. Errors: not JSON, missing keys, the requested style absent (naming it).
[[nodiscard]] Result<ObjectiveBreakdown> objective_from_summary(const std::string& json_text, const ObjectiveWeights& w);

}  // namespace visnav::stability
