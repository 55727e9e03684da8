// `visnav stability-sim`: the seed 002 Sec. 3.8 experiment (docs/convergence.md).
#include <cstdio>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <thread>

#include "cli_util.hpp"
#include "commands.hpp"
#include "visnav_stability/scenario_sim.hpp"

namespace visnav::stability {
namespace {

constexpr const char* kUsage =
    "usage: visnav stability-sim [--scenarios N] [--threads T] [--seed S] [--loops K] [--converged-ratio R]\n"
    "                            [--curvature-min C] [--curvature-max C] [--landmark-min L] [--landmark-max L]\n"
    "                            [--initial-error-max E] [--odom-error-max E] [--heading-error-max-deg D]\n"
    "                            [--corners-min N] [--corners-max N] [--only SEED] [--json FILE]\n"
    "\n"
    "Seed 002 Sec. 3.8: replays N random closed routes (random star polygons whose sides are arcs of\n"
    "curvature 0.001-1 1/m, landmarks 0.1-2 m away, initial error up to 1 m in x and y, odometric\n"
    "error up to 5 %, heading-estimation error up to 5 deg) for K loops each, twice with the same\n"
    "disturbances (from the initial error and from zero), and counts the scenarios whose initial\n"
    "error died out (final gap <= R x initial error). Multi-threaded, with a progress bar.\n"
    "\n"
    "  --scenarios N          scenarios (default 1000000, the paper's count)\n"
    "  --threads T            worker threads (default: the number of cores)\n"
    "  --seed S               first scenario seed (default 1); scenario i uses seed S+i\n"
    "  --loops K              loops replayed per scenario (default 10)\n"
    "  --converged-ratio R    converged when final gap <= R x initial error (default 0.1)\n"
    "  --curvature-min/-max   arc curvature range, log-uniform (default 0.001 / 1 1/m)\n"
    "  --landmark-min/-max    landmark distance l (default 0.1 / 2 m)\n"
    "  --initial-error-max E  |x0|, |y0| up to E (default 1 m)\n"
    "  --odom-error-max E     odometric scale error up to +-E (default 0.05)\n"
    "  --heading-error-max-deg D  heading-estimation error bound up to D (default 5)\n"
    "  --corners-min/-max N   corners of the route polygon (default 3 / 8)\n"
    "  --only SEED            simulate one scenario and print it loop by loop\n"
    "  --json FILE            also write the summary as JSON\n"
    "Exit status: 0 done, 1 error, 2 usage error.\n";

std::string pct(std::uint64_t a, std::uint64_t b) { return cli::fixed(b ? 100.0 * static_cast<double>(a) / static_cast<double>(b) : 0.0, 3); }

int print_one(const ScenarioRanges& ranges, const SimParams& params, std::uint64_t seed) {
  const Scenario s = draw_scenario(ranges, seed);
  const ScenarioOutcome o = simulate(s, params);
  std::cout << "scenario " << seed << ": " << s.arcs.size() << " arcs, length " << cli::fixed(s.length_m(), 2)
            << " m, polygon radius " << cli::fixed(s.radius_m, 2) << " m, landmarks " << cli::fixed(s.landmark_m, 3)
            << " m, initial error (" << cli::fixed(s.x0_m, 3) << ", " << cli::fixed(s.y0_m, 3) << ") m, odometry "
            << cli::fixed(100.0 * s.odom_scale_error, 2) << " %, heading error <= "
            << cli::fixed(s.heading_error_bound_rad * 180.0 / std::numbers::pi, 2) << " deg\n";
  std::cout << "| arc | curvature [1/m] | length [m] | turn at its start [deg] |\n| --- | --- | --- | --- |\n";
  for (std::size_t j = 0; j < s.arcs.size(); ++j)
    std::cout << "| " << j << " | " << cli::fixed(s.arcs[j].curvature_per_m, 4) << " | " << cli::fixed(s.arcs[j].length_m, 2)
              << " | " << cli::fixed(s.corner_turn_rad[j] * 180.0 / std::numbers::pi, 1) << " |\n";
  std::cout << "error at the end of each loop [m]:";
  for (double e : o.loop_error_m) std::cout << " " << cli::fixed(e, 3);
  std::cout << "\nfinal gap / initial error " << cli::fixed(o.gap_ratio, 4) << ", steady error (zero start) "
            << cli::fixed(o.steady_error_m, 3) << " m: " << (o.converged ? "converged" : "did not converge")
            << (o.growing ? " (error still growing)" : "") << "\n";
  return 0;
}

int run(int argc, char** argv) {
  if (cli::print_help_if_asked(argc, argv, kUsage)) return 0;
  ScenarioRanges ranges;
  SimParams params;
  std::uint64_t scenarios = 1000000, first_seed = 1;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::optional<std::uint64_t> only;
  std::string json;
  auto parse = [&]() -> Status {
    for (cli::OptionReader in(argc, argv); in.next();) {
      const std::string& a = in.arg();
      if (a == "--scenarios") { VISNAV_ASSIGN(double v, in.number(1, 1e9)); scenarios = static_cast<std::uint64_t>(v); }
      else if (a == "--threads") { VISNAV_ASSIGN(double v, in.number(1, 256)); threads = static_cast<int>(v); }
      else if (a == "--seed") { VISNAV_ASSIGN(double v, in.number(0, 1e15)); first_seed = static_cast<std::uint64_t>(v); }
      else if (a == "--loops") { VISNAV_ASSIGN(double v, in.number(1, 1000)); params.loops = static_cast<int>(v); }
      else if (a == "--converged-ratio") { VISNAV_ASSIGN(params.converged_ratio, in.number(1e-9, 0.999)); }
      else if (a == "--curvature-min") { VISNAV_ASSIGN(ranges.curvature_min_per_m, in.number(1e-9, 100)); }
      else if (a == "--curvature-max") { VISNAV_ASSIGN(ranges.curvature_max_per_m, in.number(1e-9, 100)); }
      else if (a == "--landmark-min") { VISNAV_ASSIGN(ranges.landmark_min_m, in.number(1e-3, 1000)); }
      else if (a == "--landmark-max") { VISNAV_ASSIGN(ranges.landmark_max_m, in.number(1e-3, 1000)); }
      else if (a == "--initial-error-max") { VISNAV_ASSIGN(ranges.initial_error_max_m, in.number(0, 100)); }
      else if (a == "--odom-error-max") { VISNAV_ASSIGN(ranges.odom_error_max, in.number(0, 0.49)); }
      else if (a == "--heading-error-max-deg") { VISNAV_ASSIGN(ranges.heading_error_max_deg, in.number(0, 44)); }
      else if (a == "--corners-min") { VISNAV_ASSIGN(double v, in.number(3, 64)); ranges.corners_min = static_cast<int>(v); }
      else if (a == "--corners-max") { VISNAV_ASSIGN(double v, in.number(3, 64)); ranges.corners_max = static_cast<int>(v); }
      else if (a == "--only") { VISNAV_ASSIGN(double v, in.number(0, 1e15)); only = static_cast<std::uint64_t>(v); }
      else if (a == "--json") { VISNAV_ASSIGN(json, in.value()); }
      else return fail("unknown option '" + a + "'");
    }
    VISNAV_TRY(ranges.validate());
    return params.validate();
  };
  if (auto st = parse(); !st) return cli::usage_error("stability-sim", st.error().message, kUsage);
  if (only) return print_one(ranges, params, *only);

  std::cout << "stability-sim: " << scenarios << " scenarios (seeds " << first_seed << ".." << first_seed + scenarios - 1
            << "), " << params.loops << " loops each, " << threads << " threads\n";
  cli::ProgressLine bar;
  auto sum = run_batch(ranges, params, first_seed, scenarios, threads, [&](std::uint64_t done) {
    bar.show("scenarios", static_cast<double>(done), static_cast<double>(scenarios), "scenarios");
  });
  bar.end();
  if (!sum) {
    std::cerr << "stability-sim: " << sum.error().message << "\n";
    return 1;
  }
  const BatchSummary& s = *sum;
  const std::uint64_t bounded = s.scenarios - s.converged - s.growing;
  std::cout << "\n| scenarios | converged | not converged, bounded | not converged, growing | not finite | time [s] |\n"
            << "| --- | --- | --- | --- | --- | --- |\n"
            << "| " << s.scenarios << " | " << s.converged << " (" << pct(s.converged, s.scenarios) << " %) | " << bounded
            << " (" << pct(bounded, s.scenarios) << " %) | " << s.growing << " (" << pct(s.growing, s.scenarios)
            << " %) | " << s.not_finite << " | " << cli::fixed(s.seconds, 1) << " |\n\n";
  std::cout << "| quantile | final gap / initial error | steady error [m] | loop-1 error / initial error |\n"
            << "| --- | --- | --- | --- |\n";
  const char* names[] = {"50 %", "90 %", "99 %", "99.9 %", "max"};
  for (std::size_t i = 0; i < s.gap_ratio_quantiles.size(); ++i)
    std::cout << "| " << names[i] << " | " << cli::fixed(s.gap_ratio_quantiles[i], 4) << " | "
              << cli::fixed(s.steady_error_quantiles_m[i], 3) << " | " << cli::fixed(s.first_loop_ratio_quantiles[i], 3)
              << " |\n";
  std::cout << "\nseed 002 Sec. 3.8 reports that all 1000000 scenarios converged; here " << s.converged << " of "
            << s.scenarios << " (" << pct(s.converged, s.scenarios) << " %) did.\n";
  std::cout << "scenarios meeting the linear model's assumption (landmark distance l > initial error): "
            << s.assumption_met << ", of which " << s.assumption_met_converged << " ("
            << pct(s.assumption_met_converged, s.assumption_met) << " %) converged; the others: "
            << s.converged - s.assumption_met_converged << " of " << s.scenarios - s.assumption_met << " ("
            << pct(s.converged - s.assumption_met_converged, s.scenarios - s.assumption_met) << " %)\n";
  if (!s.failed_seeds.empty()) {
    std::cout << "first scenarios that did not converge (inspect with --only SEED):";
    for (auto f : s.failed_seeds) std::cout << " " << f;
    std::cout << "\n";
  }
  std::cout << "largest final gap / initial error: " << cli::fixed(s.worst_gap_ratio, 4) << " (seed " << s.worst_gap_seed
            << ")\n";
  if (!json.empty()) {
    std::ofstream f(json);
    auto arr = [](const std::vector<double>& v) {
      std::string out = "[";
      for (std::size_t i = 0; i < v.size(); ++i) {
        if (i > 0) out += ',';
        out += cli::fixed(v[i], 6);
      }
      return out + "]";
    };
    f << "{\"scenarios\":" << s.scenarios << ",\"converged\":" << s.converged << ",\"growing\":" << s.growing
      << ",\"not_finite\":" << s.not_finite << ",\"assumption_met\":" << s.assumption_met
      << ",\"assumption_met_converged\":" << s.assumption_met_converged << ",\"loops\":" << params.loops << ",\"first_seed\":" << first_seed
      << ",\"quantiles\":[0.5,0.9,0.99,0.999,1.0],\"gap_ratio\":" << arr(s.gap_ratio_quantiles)
      << ",\"steady_error_m\":" << arr(s.steady_error_quantiles_m) << ",\"seconds\":" << cli::fixed(s.seconds, 2) << "}\n";
    if (!f) {
      std::cerr << "stability-sim: cannot write " << json << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace

int stability_sim_command(int argc, char** argv, HostServices& /*host*/) { return run(argc, argv); }

}  // namespace visnav::stability
