// libFuzzer target: the simulator's world and route files (YAML). The first byte chooses which.
#include <cstdint>

#include "visnav_sim/route.hpp"
#include "visnav_sim/world.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  if (data[0] & 1) {
    (void)visnav::sim::parse_world(text, "fuzz_world.yaml", "/nonexistent");
  } else {
    (void)visnav::sim::parse_route(text, "fuzz_route.yaml");
  }
  return 0;
}
