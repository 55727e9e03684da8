// libFuzzer target: the feature_replay payload body readers (segment maps, local-map paths) —
// what `visnav map validate` and a mission's route check run on every edge. Invariant: a body
// that decodes survives a round trip (reserved fields are ignored on read, so the first
// re-serialisation may differ from the input; the second must equal the first).
#include <cstdint>
#include <cstdlib>
#include <span>

#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> body(data, size);
  if (auto seg = visnav::feature_replay::SegmentMap::deserialize(body)) {
    (void)seg->validate();
    const auto once = seg->serialize();
    auto reread = visnav::feature_replay::SegmentMap::deserialize(once);
    if (!reread) std::abort();
    const auto twice = reread->serialize();
    if (once != twice) std::abort();
  }
  if (auto path = visnav::feature_replay::LocalMapPath::deserialize(body)) (void)path->validate();
  return 0;
}
