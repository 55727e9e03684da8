// libFuzzer target: arbitrary bytes as an edge payload file (map_format::parse_payload), and the
// accepted bodies through PayloadReader. Invariants checked beyond "no crash":
//  * an accepted file is canonical: re-encoding its kind, id and body gives the input back;
//  * the body view lies inside the input.
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "visnav/map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> file(data, size);
  auto parsed = visnav::map_format::parse_payload(file, "fuzz.bin");
  if (!parsed) {
    if (parsed.error().message.rfind("fuzz.bin: ", 0) != 0) std::abort();  // errors name the file
    // Also exercise the body reader on arbitrary bytes.
    visnav::PayloadReader r(file);
    for (int i = 0; i < 64 && !r.at_end(); ++i) {
      switch (i % 4) {
        case 0: if (!r.get<std::uint32_t>()) return 0; break;
        case 1: if (!r.get<double>()) return 0; break;
        case 2: if (!r.get_bytes()) return 0; break;
        default: if (!r.get_string()) return 0; break;
      }
    }
    return 0;
  }
  const auto& v = *parsed;
  if (v.body.data() < data || v.body.data() + v.body.size() > data + size) std::abort();
  const auto again = visnav::map_format::encode_payload(v.kind, v.edge_id, v.body);
  if (again.size() != size || std::memcmp(again.data(), data, size) != 0) std::abort();
  return 0;
}
