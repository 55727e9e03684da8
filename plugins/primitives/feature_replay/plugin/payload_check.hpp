// feature_replay plugin — the body checks of the feature edge kinds (the plugin's payload_checks,
// `visnav map validate`) and of their learned experiences (`visnav map experiences --check`).
#pragma once

#include <algorithm>
#include <cmath>
#include <exception>
#include <span>
#include <string>

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

/// Decodes `body` as a `Body` (SegmentMap or LocalMapPath), validates it and its length.
template <typename Body>
Status check_body(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept {
  try {
    auto parsed = Body::deserialize(body);
    if (!parsed) return std::move(parsed).error();
    if (auto st = parsed->validate(); !st) return st;
    return check_length(parsed->length_m, edge);
  } catch (const std::exception& e) {
    return fail(std::string("payload reader threw: ") + e.what());
  } catch (...) {
    return fail("payload reader threw a non-standard exception");
  }
}

}  // namespace visnav::feature_replay
