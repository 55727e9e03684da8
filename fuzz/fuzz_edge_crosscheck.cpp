// libFuzzer target: the cross-check of a map's graph record against its payload body (issue 39)
// — what `visnav map validate` and the check before a replay run on every feature edge. The first
// 10 input bytes choose the record (declared length_m as a double, whether the edge closes on its
// own node, segment or local-map kind); the rest is the body. Invariants, whatever the input:
//   * an accepted edge declares a finite length within max_length_for_evidence_m() of the
//     evidence its body carries and within the graph tolerance of the body's own length;
//   * a feature_segment edge from a node to itself is never accepted.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <type_traits>

#include "payload_check.hpp"  // plugins/primitives/feature_replay/plugin (the plugin's checks)
#include "visnav/edge_evidence.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"

namespace fr = visnav::feature_replay;

namespace {

template <typename Body>
void check_one(std::span<const std::uint8_t> body, const visnav::EdgeRecord& edge) {
  const visnav::Status verdict = fr::check_body<Body>(body, edge);
  if (!verdict.ok()) return;
  auto parsed = Body::deserialize(body);
  if (!parsed) std::abort();  // accepted but does not decode
  if (!std::isfinite(edge.length_m)) std::abort();
  if (edge.length_m > visnav::max_length_for_evidence_m(fr::evidence_end_m(*parsed)) + 1e-9) std::abort();
  if (!fr::check_length(parsed->length_m, edge).ok()) std::abort();
  if constexpr (std::is_same_v<Body, fr::SegmentMap>)
    if (edge.from == edge.to) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 10) return 0;
  visnav::EdgeRecord edge;
  edge.id = "e0";
  std::memcpy(&edge.length_m, data, sizeof(double));
  edge.from = "n0";
  edge.to = (data[8] & 1) != 0 ? "n0" : "n1";
  const std::span<const std::uint8_t> body(data + 10, size - 10);
  if ((data[9] & 1) != 0) {
    edge.kind = fr::kLocalMapsKind;
    check_one<fr::LocalMapPath>(body, edge);
  } else {
    edge.kind = fr::kSegmentKind;
    check_one<fr::SegmentMap>(body, edge);
  }
  return 0;
}
