// The seed 002 Sec. 3.8 experiment: many random closed routes replayed by a bearing-only
// teach-and-repeat robot, checking that the position error converges.
//
// A scenario is a closed route of n arcs between the corners of a random star-shaped polygon
// (the robot turns in place at a corner, as at a node of the hybrid map), the landmark distance
// l, an initial position error (x0, y0) in the frame of the first arc, an odometric scale error
// and a bound on the heading-estimation error. All ranges are the paper's (ScenarioRanges):
// curvature 0.001–1 1/m (log-uniform per arc), l 0.1–2 m, |x0|, |y0| ≤ 1 m, odometry ≤ 5 %,
// heading error ≤ 5°.
//
// The replay integrates the error (x along-track, y lateral, in the frame of the reference point
// that odometry says the robot is at) with seed 002 eq. (1), which is exact for a reference
// frame moving along an arc of curvature κ:
//   ẋ = κ·v_ref·y − v_ref + v·cos φ,   ẏ = −κ·v_ref·x + v·sin φ,   φ = −atan(y / l) + δ,
// where v_ref = (1 + odometric error)·v is how fast the reference point advances and δ is the
// heading-estimation error, redrawn for every local map (every `local_map_spacing_m` of the
// route) and every loop. At a corner the reference frame turns by the corner angle. No
// small-angle approximation is made (the paper's linear model, eq. 2–4, is what the sampled
// behaviour is compared against).
//
// Convergence (the paper's "gradually converged to the intended trajectory"): the scenario is
// run twice with the same disturbances, from (x0, y0) and from zero error; it converges when
// after `loops` loops the two robots are closer than `converged_ratio` × their initial
// distance — the initial error has died out and what is left is the steady error that the
// disturbances cause (reported separately). Pure and deterministic: a scenario depends only on
// (ranges, seed). Thread-safe (no shared state).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::stability {

/// Ranges of the random scenarios; defaults are seed 002 Sec. 3.8 (and our route shapes).
struct ScenarioRanges {
  double curvature_min_per_m = 0.001;  ///< arc curvature magnitude, log-uniform in [min, max]
  double curvature_max_per_m = 1.0;
  double landmark_min_m = 0.1;         ///< landmark distance l, uniform
  double landmark_max_m = 2.0;
  double initial_error_max_m = 1.0;    ///< |x0|, |y0| uniform in [0, max], random signs
  double odom_error_max = 0.05;        ///< odometric scale error uniform in [−max, max]
  double heading_error_max_deg = 5.0;  ///< per scenario a bound b uniform in [0, max]; δ uniform in [−b, b]
  int corners_min = 3;                 ///< corners of the polygon, uniform integer
  int corners_max = 8;
  double radius_min_m = 2.0;           ///< polygon size (centre to corner), uniform; shrunk when an
  double radius_max_m = 10.0;          ///< arc of the drawn curvature cannot span a side
  double local_map_spacing_m = 0.5;    ///< δ is redrawn per local map of this spacing
  [[nodiscard]] Status validate() const;
};

struct SimParams {
  int loops = 10;                 ///< loops replayed, ≥ 1
  double converged_ratio = 0.1;   ///< gap after `loops` ≤ ratio × initial gap → converged; (0, 1)
  double max_step_m = 0.1;        ///< integration step bound; the step is min(this, l / 4)
  double min_step_m = 0.005;
  [[nodiscard]] Status validate() const;
};

/// One arc of a route: starts at (x_m, y_m) with heading heading_rad, signed curvature.
struct Arc {
  double x_m = 0.0, y_m = 0.0, heading_rad = 0.0;
  double curvature_per_m = 0.0;  ///< signed (left > 0); |κ| is the drawn curvature
  double length_m = 0.0;
};

struct Scenario {
  std::uint64_t seed = 0;
  std::vector<Arc> arcs;                 ///< closed: the last arc ends at the first arc's start
  std::vector<double> corner_turn_rad;   ///< turn at the start of arc i (from arc i−1's end heading)
  double landmark_m = 1.0;
  double x0_m = 0.0, y0_m = 0.0;         ///< initial error in the first arc's frame
  double odom_scale_error = 0.0;         ///< odometry reads (1 + e) × the distance driven
  double heading_error_bound_rad = 0.0;
  double radius_m = 0.0;                 ///< polygon radius used
  double local_map_spacing_m = 0.5;      ///< δ is redrawn per local map of this spacing
  [[nodiscard]] double length_m() const;
};

/// Draws scenario `seed` (deterministic; independent of thread and order).
[[nodiscard]] Scenario draw_scenario(const ScenarioRanges& ranges, std::uint64_t seed);

struct ScenarioOutcome {
  bool converged = false;
  bool finite = true;                 ///< false if the state blew up (never seen; counted apart)
  /// The error is still growing at the end: last loop's error > 1.5 × max(initial error, error
  /// after loop ⌈loops/2⌉) and > 1 m.
  bool growing = false;
  double initial_error_m = 0.0;       ///< |(x0, y0)|
  std::vector<double> loop_error_m;   ///< distance to the route start at the end of each loop
  double gap_ratio = 0.0;             ///< final gap / initial gap of the paired runs
  double steady_error_m = 0.0;        ///< error at the end of the last loop of the zero-start run
};

/// Replays a scenario (paired runs, see the file comment).
[[nodiscard]] ScenarioOutcome simulate(const Scenario& s, const SimParams& p);

/// Aggregate over many scenarios.
struct BatchSummary {
  std::uint64_t scenarios = 0;
  std::uint64_t converged = 0;
  std::uint64_t not_finite = 0;
  std::uint64_t growing = 0;   ///< not converged and the error still growing (ScenarioOutcome::growing)
  /// Scenarios meeting the linear model's assumption l > |initial error| (seed 002 Sec. 2.5
  /// assumes l ≫ |y|), and how many of those converged.
  std::uint64_t assumption_met = 0;
  std::uint64_t assumption_met_converged = 0;
  std::vector<std::uint64_t> failed_seeds;       ///< first 20 that did not converge
  double worst_gap_ratio = 0.0;
  std::uint64_t worst_gap_seed = 0;
  std::vector<double> gap_ratio_quantiles;       ///< 50, 90, 99, 99.9, 100 %
  std::vector<double> steady_error_quantiles_m;  ///< same quantiles
  std::vector<double> first_loop_ratio_quantiles;  ///< loop-1 error / initial error, same quantiles
  double seconds = 0.0;
};

/// Runs scenarios first_seed .. first_seed + count − 1 on `threads` threads. `progress(done)` is
/// called from the calling thread about every 0.2 s and at the end; `cancel` (may be null) stops
/// early. Errors: invalid ranges or params, threads < 1.
[[nodiscard]] Result<BatchSummary> run_batch(const ScenarioRanges& ranges, const SimParams& params, std::uint64_t first_seed,
                                             std::uint64_t count, int threads,
                                             const std::function<void(std::uint64_t done)>& progress = {});

/// Seed-mixing generator (splitmix64): small, fast, statistically fine for this use.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  std::uint64_t state_;
};

}  // namespace visnav::stability
