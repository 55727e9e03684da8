// Seed 000 Sec. 5 as code: per-edge N_i = R_iᵀ·diag(1, e^(−k·s))·R_i, loop product, eigenvalues.
#include "visnav_stability/error_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace visnav::stability {
namespace {

double wrap_pi(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

// R rotates odom-frame vectors into the edge frame (x along the edge).
Eigen::Matrix2d edge_rotation(double direction_rad) {
  const double c = std::cos(direction_rad), s = std::sin(direction_rad);
  Eigen::Matrix2d r;
  r << c, s, -s, c;
  return r;
}

double spectral_radius_of(const Eigen::Matrix2d& m) {
  Eigen::EigenSolver<Eigen::Matrix2d> es(m, false);
  return std::max(std::abs(es.eigenvalues()[0]), std::abs(es.eigenvalues()[1]));
}

}  // namespace

ConvergenceModels ConvergenceModels::defaults() {
  return ConvergenceModels{{{"path_following", 0.366}, {"feature_segment", 0.055}, {"feature_localmaps", 0.053}}};
}

Status ConvergenceModels::validate() const {
  for (const auto& [kind, k] : k_per_m) {
    if (!map_format::valid_kind(kind)) return Error{"convergence model: '" + kind + "' is not a valid primitive kind", ErrorCode::invalid_value, {{}, 0, kind}};
    if (!std::isfinite(k) || k < 0.0)
      return Error{"convergence model: k of '" + kind + "' must be finite and >= 0 1/m, got " + std::to_string(k), ErrorCode::out_of_range, {{}, 0, kind}};
  }
  return ok();
}

const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::converges: return "converges";
    case Verdict::marginal: return "marginal";
    case Verdict::does_not_converge: return "does not converge";
  }
  return "?";
}

Status StabilityParams::validate() const {
  if (!(marginal_radius > 0.0 && marginal_radius < 1.0))
    return Error{"marginal_radius must be in (0, 1), got " + std::to_string(marginal_radius), ErrorCode::out_of_range, {{}, 0, "marginal_radius"}};
  if (!(unit_tolerance > 0.0 && unit_tolerance < 0.01))
    return Error{"unit_tolerance must be in (0, 0.01), got " + std::to_string(unit_tolerance), ErrorCode::out_of_range, {{}, 0, "unit_tolerance"}};
  if (!(min_turn_rad >= 0.0 && min_turn_rad < 1.0))
    return Error{"min_turn_rad must be in [0, 1), got " + std::to_string(min_turn_rad), ErrorCode::out_of_range, {{}, 0, "min_turn_rad"}};
  return ok();
}

Eigen::Matrix2d loop_matrix(const std::vector<ModelEdge>& edges, const std::vector<double>& k_per_m) {
  Eigen::Matrix2d total = Eigen::Matrix2d::Identity();
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Eigen::Matrix2d r = edge_rotation(edges[i].direction_rad);
    Eigen::Matrix2d m = Eigen::Matrix2d::Identity();
    m(1, 1) = std::exp(-k_per_m[i] * edges[i].length_m);
    total = (r.transpose() * m * r) * total;  // N_i applied after the edges before it
  }
  return total;
}

Result<StabilityReport> analyse_loop(const std::vector<ModelEdge>& edges, const ConvergenceModels& models,
                                     const StabilityParams& params) {
  VISNAV_TRY(models.validate());
  VISNAV_TRY(params.validate());
  if (edges.size() < 2) {
    return fail(ErrorCode::inconsistent, edges.empty() ? std::string("the route has no edge: nothing to analyse")
                              : "the route has one edge ('" + edges[0].id +
                                    "'): a closed route needs at least two edges with a turn between them "
                                    "(seed 000 Sec. 5.3)");
  }
  std::vector<double> k(edges.size());
  StabilityReport rep;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const ModelEdge& e = edges[i];
    if (!std::isfinite(e.length_m) || e.length_m <= 0.0)
      return Error{"edge '" + e.id + "': length_m must be finite and > 0, got " + std::to_string(e.length_m), ErrorCode::out_of_range, {{}, 0, e.id}};
    if (!std::isfinite(e.direction_rad))
      return Error{"edge '" + e.id + "': direction is not finite", ErrorCode::invalid_value, {{}, 0, e.id}};
    auto it = models.k_per_m.find(e.kind);
    if (it == models.k_per_m.end())
      return Error{"edge '" + e.id + "': primitive '" + e.kind + "' has no convergence model; give its k with --k " +
                  e.kind + "=<1/m>", ErrorCode::not_found, {{}, 0, e.id}};
    k[i] = it->second;
    EdgeContribution c;
    c.edge = e;
    c.k_per_m = k[i];
    c.lateral_factor = std::exp(-k[i] * e.length_m);
    c.turn_to_next_rad = wrap_pi(edges[(i + 1) % edges.size()].direction_rad - e.direction_rad);
    rep.edges.push_back(std::move(c));
  }

  // Express N̆ in the first edge's frame so that x is along-track and y lateral at the start.
  const Eigen::Matrix2d r0 = edge_rotation(edges[0].direction_rad);
  rep.loop_matrix = r0 * loop_matrix(edges, k) * r0.transpose();
  Eigen::EigenSolver<Eigen::Matrix2d> es(rep.loop_matrix, false);
  rep.eigenvalue[0] = es.eigenvalues()[0];
  rep.eigenvalue[1] = es.eigenvalues()[1];
  if (std::abs(rep.eigenvalue[1]) > std::abs(rep.eigenvalue[0])) std::swap(rep.eigenvalue[0], rep.eigenvalue[1]);
  rep.spectral_radius = std::abs(rep.eigenvalue[0]);
  rep.along_track_contraction = rep.loop_matrix.col(0).norm();
  rep.lateral_contraction = rep.loop_matrix.col(1).norm();
  Eigen::JacobiSVD<Eigen::Matrix2d> svd(rep.loop_matrix);
  rep.worst_case_contraction = svd.singularValues()(0);

  const double rho = rep.spectral_radius;
  if (rho >= 1.0 - params.unit_tolerance) {
    rep.verdict = Verdict::does_not_converge;
    rep.loops_to_halve = std::numeric_limits<double>::infinity();
  } else {
    rep.verdict = rho > params.marginal_radius ? Verdict::marginal : Verdict::converges;
    rep.loops_to_halve = rho <= 0.0 ? 0.0 : std::log(0.5) / std::log(rho);
  }

  // Which edge limits: the drop of ρ when that edge's k is doubled.
  for (std::size_t i = 0; i < edges.size(); ++i) {
    std::vector<double> k2 = k;
    k2[i] *= 2.0;
    rep.edges[i].radius_gain_if_doubled = rho - spectral_radius_of(loop_matrix(edges, k2));
  }
  std::vector<std::size_t> order(edges.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return rep.edges[a].radius_gain_if_doubled > rep.edges[b].radius_gain_if_doubled;
  });
  for (std::size_t i : order) {
    if (rep.limiting.size() == 3) break;
    if (rep.edges[i].radius_gain_if_doubled > 1e-6) rep.limiting.push_back(i);  // ignore round-off
  }

  bool all_collinear = true;
  for (const auto& c : rep.edges) {
    const double t = std::abs(c.turn_to_next_rad);
    if (t > params.min_turn_rad && std::numbers::pi - t > params.min_turn_rad) all_collinear = false;
    if (c.k_per_m == 0.0)
      rep.notes.push_back("edge '" + c.edge.id + "' (" + c.edge.kind + ") has k = 0: it never corrects lateral error");
  }
  if (all_collinear)
    rep.notes.push_back("all edges are collinear (every turn is ~0 or ~180 deg): along-track error is never "
                        "turned into lateral error, so it is never corrected (seed 000 Sec. 5.3)");
  return rep;
}

Result<std::vector<ModelEdge>> closed_route(const MapStore& map, const std::vector<std::string>& edge_ids) {
  std::vector<const EdgeRecord*> route;
  if (edge_ids.empty()) {
    for (const auto& e : map.edges()) route.push_back(&e);
  } else {
    for (const auto& id : edge_ids) {
      const EdgeRecord* e = map.find_edge(id);
      if (e == nullptr) return Error{map.graph_path() + ": no edge '" + id + "'", ErrorCode::not_found, {map.graph_path(), 0, id}};
      route.push_back(e);
    }
  }
  if (route.empty()) return fail(ErrorCode::missing, {map.graph_path()}, "the map has no edge");
  for (std::size_t i = 0; i + 1 < route.size(); ++i) {
    if (route[i]->to != route[i + 1]->from)
      return Error{map.graph_path() + ": edge '" + route[i]->id + "' ends at node '" + route[i]->to + "' but the next edge '" +
                  route[i + 1]->id + "' starts at '" + route[i + 1]->from + "': not a chain (give the loop with --edges)", ErrorCode::inconsistent, {map.graph_path(), 0, route[i]->id}};
  }
  if (route.back()->to != route.front()->from)
    return fail(ErrorCode::inconsistent, {map.graph_path()}, "the route is not closed: it ends at node '" + route.back()->to +
                "' but starts at '" + route.front()->from + "'");
  // A map taught by a robot that cannot turn on the spot (ScriptedOperator with
  // min_turning_radius_m) has its nodes where the corner arcs start, and each edge starts where
  // an arc ended (start gap about R·|θ|): the chord between nodes would cut the corners. Such a
  // map is recognised by the navigation plugin's edge statistic "start_gap_m" (the distance
  // driven between two edges, centimetres for a turn on the spot) and its straight edges'
  // start azimuths are used instead.
  constexpr double kArcGapM = 0.5;
  const bool taught_on_arcs = std::any_of(route.begin(), route.end(), [](const EdgeRecord* e) {
    auto it = e->statistics.find("start_gap_m");
    return it != e->statistics.end() && it->second > kArcGapM;
  });
  std::vector<ModelEdge> out;
  for (const EdgeRecord* e : route) {
    ModelEdge m{e->id, e->kind, e->length_m, e->azimuth_rad};
    const NodeRecord* a = map.find_node(e->from);
    const NodeRecord* b = map.find_node(e->to);
    if (!taught_on_arcs && a != nullptr && b != nullptr && a->position_hint && b->position_hint) {
      const double dx = b->position_hint->x_m - a->position_hint->x_m;
      const double dy = b->position_hint->y_m - a->position_hint->y_m;
      if (std::hypot(dx, dy) > 1e-6) m.direction_rad = std::atan2(dy, dx);
    }
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace visnav::stability
