// visnav SDK — a map edge's declared length against its own evidence (issue 39).
//
// An edge's graph record says how long it is (length_m); the replay drives until that distance.
// Its payload says where along the edge the teacher saw something: the last landmark's last
// sighting (feature segments), the last local map (feature local maps), the last thumbnail or
// offset sample (path following), the last reference image (visual memory). A map whose record
// and body were both raised to 500 m (checksum recomputed) is self-consistent but not believable:
// the robot would drive 494 m past anything it could recognise. The payload checks of the
// shipped primitives therefore require
//
//     length_m <= evidence_end_m + max(kEvidenceSlackM, kEvidenceSlackFraction * evidence_end_m)
//
// at `visnav map validate` and before a route is driven. The slack covers what a teach run
// legitimately records after its last sighting (the stop, a blind stretch before the node, taught
// on odometry); the replay's lost detection stops within max_blind_m of the evidence's end.
//
// Header-only, pure, no allocation except the error message.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>

#include "visnav/result.hpp"

namespace visnav {

// Campus maps hold feature segments whose last landmark is 4.95 m before the edge's end (8.28 m
// edge, landmarks to 3.33 m: a blind tail taught on odometry), so the slack is larger than the
// default max_blind_m (5 m); the replay stops within max_blind_m of the evidence anyway.
inline constexpr double kEvidenceSlackM = 10.0;         ///< absolute part of the slack, m
inline constexpr double kEvidenceSlackFraction = 0.25;  ///< share of the evidence's extent

/// The longest length an edge whose evidence ends at `evidence_end_m` may declare.
[[nodiscard]] inline double max_length_for_evidence_m(double evidence_end_m) {
  const double end = std::max(0.0, evidence_end_m);
  return end + std::max(kEvidenceSlackM, kEvidenceSlackFraction * end);
}

/// ok() when `length_m` is within max_length_for_evidence_m(evidence_end_m); else an
/// inconsistent error naming both figures and what the evidence is ("landmarks", "local maps").
[[nodiscard]] inline Status check_length_evidence(double length_m, double evidence_end_m, std::string_view evidence) {
  const double limit_m = max_length_for_evidence_m(evidence_end_m);
  if (std::isfinite(length_m) && length_m <= limit_m) return ok();
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "declared length %.2f m is not backed by the edge's own evidence: its %.*s end at %.2f m "
                "(at most %.2f m may be declared)",
                length_m, static_cast<int>(evidence.size()), evidence.data(), evidence_end_m, limit_m);
  return fail(ErrorCode::inconsistent, std::string(buf));
}

}  // namespace visnav
