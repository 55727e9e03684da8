// feature_replay plugin — the body checks of the feature edge kinds (the plugin's payload_checks,
// `visnav map validate`) and of their learned experiences (`visnav map experiences --check`).
#pragma once

#include <algorithm>
#include <cmath>
#include <exception>
#include <span>
#include <string>

#include "visnav/edge_evidence.hpp"
#include "visnav/feature_payloads.hpp"
#include "visnav/map.hpp"

namespace visnav::feature_replay {

/// The body states the length the edge was taught with; the graph's length_m decides when the
/// replay ends. A mismatch means one of them was edited (issue 17: a body saying 500 m under a
/// 6.3 m graph entry drove 500 m), so the map is refused. 5 cm + 1 % absorbs the graph's decimal
/// formatting and a local-map body ending at the farthest recorded distance after a small reverse.
inline Status check_length(double body_length_m, const EdgeRecord& edge) {
  const double tolerance_m = 0.05 + 0.01 * std::max(std::fabs(body_length_m), std::fabs(edge.length_m));
  if (!std::isfinite(body_length_m) || std::fabs(body_length_m - edge.length_m) > tolerance_m)
    return fail("body does not match the graph: body length " + std::to_string(body_length_m) +
                " m, graph length_m " + std::to_string(edge.length_m) + " m");
  return ok();
}

/// Where the body's visual evidence ends along the edge: the farthest last sighting of a
/// landmark (a segment), the last local map (a local-map path). 0 when there is none.
inline double evidence_end_m(const SegmentMap& map) {
  double end_m = 0.0;
  for (const Landmark& l : map.landmarks) end_m = std::max(end_m, static_cast<double>(l.last_distance_m));
  return end_m;
}
inline double evidence_end_m(const LocalMapPath& path) { return path.maps.empty() ? 0.0 : path.maps.back().distance_m; }
inline const char* evidence_name(const SegmentMap&) { return "landmarks"; }
inline const char* evidence_name(const LocalMapPath&) { return "local maps"; }

/// A segment is a straight stretch between two places; only a local-map path (recorded
/// commands, driven in laps) may close on its own start node.
inline Status check_loop(const SegmentMap&, const EdgeRecord& edge) {
  if (edge.from == edge.to)
    return fail(ErrorCode::inconsistent, "edge from node '" + edge.from +
                                             "' to itself: a feature_segment edge joins two places (only a "
                                             "feature_localmaps edge may be a closed one-edge loop)");
  return ok();
}
inline Status check_loop(const LocalMapPath&, const EdgeRecord&) { return ok(); }

/// Decodes `body` as a `Body` (SegmentMap or LocalMapPath), validates it, its length against the
/// graph's and against its own evidence (edge_evidence.hpp), and a loop onto its own node.
template <typename Body>
Status check_body(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept {
  try {
    auto parsed = Body::deserialize(body);
    if (!parsed) return std::move(parsed).error();
    if (auto st = parsed->validate(); !st) return st;
    VISNAV_TRY(check_loop(*parsed, edge));
    VISNAV_TRY(check_length(parsed->length_m, edge));
    return check_length_evidence(edge.length_m, evidence_end_m(*parsed), evidence_name(*parsed));
  } catch (const std::exception& e) {
    return fail(std::string("payload reader threw: ") + e.what());
  } catch (...) {
    return fail("payload reader threw a non-standard exception");
  }
}

}  // namespace visnav::feature_replay
