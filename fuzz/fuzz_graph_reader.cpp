// libFuzzer target: arbitrary text as graph.yaml (map_detail::parse_graph). Invariants beyond
// "no crash":
//  * errors name the file;
//  * differential: whatever the fast reader accepts, the full YAML reader accepts with the same
//    graph, and cross-reference errors are identical from both;
//  * an accepted graph written back and re-read (by both readers) is identical.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "map/graph_io.hpp"

namespace {
using visnav::map_detail::emit_graph;
using visnav::map_detail::GraphParser;
using visnav::map_detail::parse_graph;

void check(bool condition) {
  if (!condition) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto full = parse_graph(text, "graph.yaml", GraphParser::full_only);
  auto fast = parse_graph(text, "graph.yaml", GraphParser::fast_only);
  if (!full) check(full.error().message.rfind("graph.yaml", 0) == 0);
  if (fast) {
    check(full.ok());
    check(emit_graph(*fast) == emit_graph(*full));
  } else if (fast.error().message.find("(fast parser)") == std::string::npos) {
    // The fast reader parsed the text; the failure is a cross-reference check.
    check(!full.ok());
    check(fast.error().message == full.error().message);
  }
  if (!full) return 0;
  const std::string written = emit_graph(*full);
  auto back_fast = parse_graph(written, "graph.yaml", GraphParser::fast_only);
  auto back_full = parse_graph(written, "graph.yaml", GraphParser::full_only);
  check(back_fast.ok() && back_full.ok());  // our own output must always parse, on the fast path
  check(emit_graph(*back_fast) == written);
  check(emit_graph(*back_full) == written);
  return 0;
}
