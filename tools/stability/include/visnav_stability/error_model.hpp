// The position-error model of a closed taught route (seed 000 Sec. 5; seed 002 Sec. 2.5).
//
// Every primitive steers the heading in proportion to the lateral offset, φ ≈ −k·y, so over an
// edge of length s the lateral error shrinks by m = e^(−k·s) while the along-track error is kept
// (odometric edge ends). In the frame of an edge with direction α this is N = Rᵀ·diag(1, m)·R;
// a loop of edges 0..n−1 maps the error at the start node to N̆ = N_{n−1}···N_0 times it (plus
// noise). The loop converges iff the spectral radius ρ(N̆) < 1, which holds unless all edges
// are collinear (seed 000 Sec. 5.3): a turn rotates the along-track error of one edge into the
// lateral error of the next, the only way along-track error is ever corrected.
//
// Frames: edge directions are headings in the map's odom frame (rad, CCW from +x). Reported
// vectors and matrices are in the frame of the first edge: x = along-track (along edge 0),
// y = lateral (left of edge 0). Contraction constants k are in 1/m.
//
// Pure functions over Eigen types and validated parameter structs; no I/O. Thread-safe.
#pragma once

#include <complex>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "visnav/map.hpp"
#include "visnav/result.hpp"

namespace visnav::stability {

/// One straight stretch of the route as the model sees it.
struct ModelEdge {
  std::string id;
  std::string kind;            ///< primitive kind (selects k)
  double length_m = 0.0;       ///< odometric length, > 0
  double direction_rad = 0.0;  ///< heading of the stretch in the odom frame
};

/// Lateral convergence constant k [1/m] per primitive kind (φ ≈ −k·y). The defaults are the
/// figures `visnav convergence` measured through the real primitives on the straight6m world
/// (docs/convergence.md): path_following 0.366, feature_segment 0.055, feature_localmaps 0.053.
/// For bearing-only feature replay k ≈ 1/l with l the mean landmark distance (seed 002 eq. 2).
struct ConvergenceModels {
  std::map<std::string, double> k_per_m;
  [[nodiscard]] static ConvergenceModels defaults();
  /// Every k finite and ≥ 0; kinds valid map kinds. Errors name the kind and value.
  [[nodiscard]] Status validate() const;
};

enum class Verdict { converges, marginal, does_not_converge };
[[nodiscard]] const char* to_string(Verdict v);

struct StabilityParams {
  /// ρ above this (but below 1) is "marginal": more than ln 0.5 / ln 0.95 ≈ 13.5 loops to halve
  /// the error. In (0, 1).
  double marginal_radius = 0.95;
  /// ρ ≥ 1 − this counts as 1 (no convergence); > 0 and small.
  double unit_tolerance = 1e-9;
  /// A turn between edges smaller than this (or this close to ±π) is reported as collinear in
  /// the notes (such a turn barely converts along-track into lateral error); ≥ 0.
  double min_turn_rad = 0.035;  // 2°
  [[nodiscard]] Status validate() const;
};

/// Per-edge part of the answer.
struct EdgeContribution {
  ModelEdge edge;
  double k_per_m = 0.0;
  double lateral_factor = 1.0;   ///< m = e^(−k·s): lateral error kept over the edge
  double turn_to_next_rad = 0.0; ///< direction change to the next edge, in (−π, π]
  /// ρ(loop) − ρ(loop with this edge's k doubled): how much improving this edge helps; the
  /// edges with the largest values limit the convergence.
  double radius_gain_if_doubled = 0.0;
};

struct StabilityReport {
  std::vector<EdgeContribution> edges;
  Eigen::Matrix2d loop_matrix = Eigen::Matrix2d::Identity();  ///< N̆ in the first edge's frame
  std::complex<double> eigenvalue[2];  ///< of N̆, |eigenvalue[0]| ≥ |eigenvalue[1]|
  double spectral_radius = 1.0;        ///< asymptotic per-loop contraction of the error
  double along_track_contraction = 1.0;  ///< |N̆·e_x|: along-track error left after one loop
  double lateral_contraction = 1.0;      ///< |N̆·e_y|: lateral error left after one loop
  double worst_case_contraction = 1.0;   ///< largest singular value of N̆ (worst one-loop case)
  double loops_to_halve = 0.0;           ///< ln 0.5 / ln ρ; +inf when ρ ≥ 1
  Verdict verdict = Verdict::does_not_converge;
  std::vector<std::size_t> limiting;     ///< edge indices, most limiting first (at most 3)
  std::vector<std::string> notes;        ///< e.g. "all edges collinear: along-track error is never corrected"
};

/// The loop matrix N̆ of `edges` (in the odom frame) for the given k per edge (same order).
[[nodiscard]] Eigen::Matrix2d loop_matrix(const std::vector<ModelEdge>& edges, const std::vector<double>& k_per_m);

/// Analyses a closed loop of at least two edges. Errors: fewer than two edges, a non-positive or
/// non-finite length (naming the edge), a kind without a model ("edge 'e3': primitive
/// 'visual_memory' has no convergence model; give its k with --k visual_memory=<1/m>").
[[nodiscard]] Result<StabilityReport> analyse_loop(const std::vector<ModelEdge>& edges, const ConvergenceModels& models,
                                                   const StabilityParams& params = {});

/// The closed route of a map: the edges `edge_ids` in that order, or (empty) every edge in
/// insertion order. Consecutive edges must chain (to == next from) and the last must end where
/// the first starts. The direction of an edge is the chord between its nodes' position hints
/// when both have one (taught odometry), else its start azimuth; on a map taught on corner arcs
/// (a car-like robot: some edge's statistic start_gap_m > 0.5 m) always the start azimuth, since
/// its nodes sit where the arcs start. Errors name the map and edge.
[[nodiscard]] Result<std::vector<ModelEdge>> closed_route(const MapStore& map, const std::vector<std::string>& edge_ids = {});

}  // namespace visnav::stability
