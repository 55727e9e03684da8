// libFuzzer target: behaviour-tree XML (BehaviorTree.CPP v4 dialect) through the public loader
// with the builtin nodes registered. Invariant: validate and load agree (a tree that validates
// loads, one that does not, does not).
#include <cstdint>
#include <cstdlib>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static visnav::bt::NodeRegistry* registry = [] {
    auto* r = new visnav::bt::NodeRegistry();
    if (!visnav::bt::register_builtin_nodes(*r)) std::abort();
    return r;
  }();
  const std::string_view xml(reinterpret_cast<const char*>(data), size);
  visnav::bt::LoadOptions options;
  options.base_dir = "/nonexistent";  // <include> never reads real files
  const auto problems = visnav::bt::validate_tree_string(xml, *registry, options);
  auto tree = visnav::bt::load_tree_string(xml, *registry, options);
  if (tree.ok() != problems.empty()) std::abort();
  return 0;
}
