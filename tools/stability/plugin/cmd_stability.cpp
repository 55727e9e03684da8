// `visnav stability MAP`: the seed 000 Sec. 5 error model of a taught map (docs/convergence.md).
//
// A plugin command rather than `visnav map stability`: the model needs each primitive's
// convergence constant k, which is knowledge about the primitives; the runtime's `map` command
// stays primitive-agnostic and never includes plugin code.
#include <cmath>
#include <iostream>
#include <numbers>

#include "cli_util.hpp"
#include "commands.hpp"
#include "visnav/map.hpp"
#include "visnav_stability/error_model.hpp"

namespace visnav::stability {
namespace {

constexpr const char* kUsage =
    "usage: visnav stability MAP [--edges e1,e2,...] [--k KIND=1/m]... [--marginal R]\n"
    "\n"
    "Builds the position-error model of a closed taught route (seed 000 Sec. 5): each edge keeps\n"
    "its along-track error and shrinks its lateral error by e^(-k*length); turns between edges\n"
    "rotate one into the other. Prints each edge's contraction, the eigenvalues of the loop\n"
    "matrix, the predicted per-loop contraction of along-track and lateral error, a verdict\n"
    "(converges / marginal / does not converge) and the edges that limit it.\n"
    "\n"
    "  MAP           map folder (graph.yaml)\n"
    "  --edges LIST  the loop, edge ids in order (default: every edge in the order it was taught;\n"
    "                consecutive edges must chain and the last must end where the first starts)\n"
    "  --k KIND=K    lateral convergence constant of a primitive kind in 1/m (repeatable). Defaults,\n"
    "                measured with `visnav convergence`: path_following 0.366, feature_segment 0.055,\n"
    "                feature_localmaps 0.053. A kind without a value is an error.\n"
    "  --marginal R  spectral radius above which the verdict is 'marginal' (default 0.95)\n"
    "Exit status: 0 converges, 3 marginal, 4 does not converge, 1 error, 2 usage error.\n";

double deg(double rad) { return rad * 180.0 / std::numbers::pi; }

std::string complex_text(std::complex<double> z) {
  if (std::abs(z.imag()) < 1e-12) return cli::fixed(z.real(), 4);
  return cli::fixed(z.real(), 4) + (z.imag() < 0 ? " - " : " + ") + cli::fixed(std::abs(z.imag()), 4) + "i";
}

int run(int argc, char** argv) {
  if (cli::print_help_if_asked(argc, argv, kUsage)) return 0;
  std::string map_dir;
  std::vector<std::string> edges;
  ConvergenceModels models = ConvergenceModels::defaults();
  StabilityParams params;
  auto parse = [&]() -> Status {
    for (cli::OptionReader in(argc, argv); in.next();) {
      const std::string& a = in.arg();
      if (a == "--edges") {
        VISNAV_ASSIGN(std::string list, in.value());
        std::string cur;
        for (char c : list + ",") {
          if (c != ',') { cur += c; continue; }
          if (cur.empty()) return fail("--edges: empty edge id in '" + list + "'");
          edges.push_back(cur);
          cur.clear();
        }
      } else if (a == "--k") {
        VISNAV_ASSIGN(std::string kv, in.value());
        const auto eq = kv.find('=');
        if (eq == std::string::npos || eq == 0) return fail("--k: '" + kv + "' must be KIND=value (1/m)");
        VISNAV_ASSIGN(double k, cli::parse_number(kv.substr(eq + 1), 0.0, 1000.0, "--k " + kv.substr(0, eq)));
        models.k_per_m[kv.substr(0, eq)] = k;
      } else if (a == "--marginal") {
        VISNAV_ASSIGN(params.marginal_radius, in.number(1e-6, 0.999999));
      } else if (!a.empty() && a[0] == '-') {
        return fail("unknown option '" + a + "'");
      } else if (map_dir.empty()) {
        map_dir = a;
      } else {
        return fail("more than one map folder given ('" + map_dir + "', '" + a + "')");
      }
    }
    if (map_dir.empty()) return fail("no map folder given");
    VISNAV_TRY(models.validate());
    return params.validate();
  };
  if (auto st = parse(); !st) return cli::usage_error("stability", st.error().message, kUsage);

  auto map = MapStore::open(map_dir);
  if (!map) {
    std::cerr << "stability: " << map.error().message << "\n";
    return 1;
  }
  auto route = closed_route(*map, edges);
  if (!route) {
    std::cerr << "stability: " << route.error().message << "\n";
    return 1;
  }
  auto rep = analyse_loop(*route, models, params);
  if (!rep) {
    std::cerr << "stability: " << map->graph_path() << ": " << rep.error().message << "\n";
    return 1;
  }
  double total_m = 0.0;
  for (const auto& e : rep->edges) total_m += e.edge.length_m;
  std::cout << "map " << map_dir << ": closed route of " << rep->edges.size() << " edges, " << cli::fixed(total_m, 1)
            << " m\n\n| edge | kind | length [m] | direction [deg] | k [1/m] | lateral kept e^(-ks) | turn to next [deg] | "
               "rho gain if k doubled |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const auto& e : rep->edges) {
    std::cout << "| " << e.edge.id << " | " << e.edge.kind << " | " << cli::fixed(e.edge.length_m, 2) << " | "
              << cli::fixed(deg(e.edge.direction_rad), 1) << " | " << cli::fixed(e.k_per_m, 3) << " | "
              << cli::fixed(e.lateral_factor, 4) << " | " << cli::fixed(deg(e.turn_to_next_rad), 1) << " | "
              << cli::fixed(e.radius_gain_if_doubled, 5) << " |\n";
  }
  const auto& m = rep->loop_matrix;
  std::cout << "\nloop matrix (frame of the first edge: x along-track, y lateral):\n"
            << "  [" << cli::fixed(m(0, 0), 4) << " " << cli::fixed(m(0, 1), 4) << "]\n"
            << "  [" << cli::fixed(m(1, 0), 4) << " " << cli::fixed(m(1, 1), 4) << "]\n"
            << "eigenvalues: " << complex_text(rep->eigenvalue[0]) << ", " << complex_text(rep->eigenvalue[1]) << "\n"
            << "spectral radius (asymptotic error kept per loop): " << cli::fixed(rep->spectral_radius, 4) << "\n"
            << "per loop: along-track error kept " << cli::fixed(rep->along_track_contraction, 4) << ", lateral error kept "
            << cli::fixed(rep->lateral_contraction, 4) << ", worst direction " << cli::fixed(rep->worst_case_contraction, 4)
            << "\n";
  if (std::isfinite(rep->loops_to_halve))
    std::cout << "loops to halve the error: " << cli::fixed(rep->loops_to_halve, 2) << "\n";
  std::cout << "verdict: " << to_string(rep->verdict) << "\n";
  if (!rep->limiting.empty()) {
    std::cout << "limiting edges (largest drop of rho when their k doubles):";
    for (std::size_t i : rep->limiting) std::cout << " " << rep->edges[i].edge.id;
    std::cout << "\n";
  }
  for (const auto& n : rep->notes) std::cout << "note: " << n << "\n";
  switch (rep->verdict) {
    case Verdict::converges: return 0;
    case Verdict::marginal: return 3;
    case Verdict::does_not_converge: return 4;
  }
  return 1;
}

}  // namespace

int stability_command(int argc, char** argv, HostServices& /*host*/) { return run(argc, argv); }

}  // namespace visnav::stability
