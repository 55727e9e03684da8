// libFuzzer target: a run config (YAML) and a `--set` override. Input = first line (the --set
// assignment) + the YAML text. Invariants beyond "no crash": errors are never empty; a config
// that parses re-parses identically after an override that failed (overrides are atomic).
#include <cstdint>
#include <cstdlib>

#include "fuzz_util.hpp"
#include "visnav/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto [line, yaml] = visnav::fuzz::split_first_line({reinterpret_cast<const char*>(data), size});
  auto root = visnav::parse_yaml_string(yaml, "fuzz.yaml");
  if (!root) {
    if (root.error().message.empty()) std::abort();
    return 0;
  }
  visnav::ConfigNode tree = *root;
  const bool applied = visnav::apply_override(tree, line).ok();
  if (!applied && !visnav::same_config(tree, *root)) std::abort();
  auto config = visnav::parse_run_config(tree, "fuzz.yaml");
  if (!config && config.error().message.empty()) std::abort();
  if (config) (void)config->run.validate();
  return 0;
}
