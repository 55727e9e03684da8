// libFuzzer target: the feature_replay payload body readers (segment maps, local-map paths) —
// what `visnav map validate` and a mission's route check run on every edge. Invariant: a body
// that decodes re-serialises to itself (the readers accept only canonical bodies).
#include <cstdint>
#include <cstdlib>
#include <span>

#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> body(data, size);
  if (auto seg = visnav::feature_replay::SegmentMap::deserialize(body)) {
    (void)seg->validate();
    const auto again = seg->serialize();
    if (again.size() != size || !std::equal(again.begin(), again.end(), data)) std::abort();
  }
  if (auto path = visnav::feature_replay::LocalMapPath::deserialize(body)) (void)path->validate();
  return 0;
}
