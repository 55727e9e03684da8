// graph.yaml readers: the fast reader (canonical layout) and the full YAML reader agree.
#include "map/graph_io.hpp"
#include "map_test_util.hpp"

namespace visnav {
namespace {

using map_detail::emit_graph;
using map_detail::Graph;
using map_detail::GraphParser;
using map_detail::parse_graph;

Graph rich_graph() {
  Graph g;
  g.name = "Karlovo náměstí \"east\" \\ tab\there\x01";
  NodeRecord a;
  a.id = "a";
  a.name = "vchod – entrance ✓";
  a.position_hint = Pose2D{-1.5, 2e-300, -3.141592653589793};
  NodeRecord b;
  b.id = "B_2-x";
  g.nodes = {a, b};
  EdgeRecord e;
  e.id = "e0";
  e.from = "a";
  e.to = "B_2-x";
  e.kind = "feature.localmaps";
  e.length_m = 0.1 + 0.2;
  e.azimuth_rad = -0.0;
  e.created = "2026-11-22T08:40:00.123Z";
  e.payload_file = "edges/e0.bin";
  e.payload_bytes = 123456789012;
  e.statistics = {{"landmarks", 812}, {"x.y-z", -1e-5}};
  EdgeRecord f = e;
  f.id = "loop";
  f.from = "B_2-x";
  f.to = "B_2-x";
  f.payload_file = "edges/loop.bin";
  f.statistics.clear();
  g.edges = {e, f};
  return g;
}

TEST(GraphReaders, FastAndFullReadersAgreeOnWhatTheWriterWrites) {
  const std::string text = emit_graph(rich_graph());
  auto fast = parse_graph(text, "g.yaml", GraphParser::fast_only);
  ASSERT_TRUE(fast) << fast.error().message << "\n" << text;
  auto full = parse_graph(text, "g.yaml", GraphParser::full_only);
  ASSERT_TRUE(full) << full.error().message;
  EXPECT_EQ(emit_graph(*fast), text);
  EXPECT_EQ(emit_graph(*full), text);
  EXPECT_EQ(fast->name, rich_graph().name);
  EXPECT_EQ(fast->nodes[0].name, rich_graph().nodes[0].name);
  EXPECT_EQ(fast->edges[0].length_m, 0.1 + 0.2);
  EXPECT_TRUE(std::signbit(fast->edges[0].azimuth_rad));
  EXPECT_EQ(fast->edges[0].payload_bytes, 123456789012u);
  // Empty maps too.
  Graph empty;
  empty.name = "";
  const std::string empty_text = emit_graph(empty);
  EXPECT_TRUE(parse_graph(empty_text, "g.yaml", GraphParser::fast_only)) << empty_text;
  EXPECT_TRUE(parse_graph(empty_text, "g.yaml", GraphParser::full_only));
}

TEST(GraphReaders, HandEditedYamlGoesThroughTheFullReader) {
  // Same graph in free YAML style: unquoted scalars, other key order, comments, flow lists.
  const std::string text =
      "# hand written\n"
      "name: corridor   # display name\n"
      "version: 1\n"
      "format: visnav-map\n"
      "nodes:\n"
      "- {id: a, name: start, outgoing: [{azimuth_rad: 0.5, edge: e0}]}\n"
      "- id: b\n"
      "edges:\n"
      "- kind: feature_segment\n"
      "  id: e0\n"
      "  from: a\n"
      "  to: b\n"
      "  length_m: 4\n"
      "  azimuth_rad: 0.5\n"
      "  created: 2026-01-01T00:00:00Z\n"
      "  payload: edges/e0.bin\n";
  EXPECT_FALSE(parse_graph(text, "g.yaml", GraphParser::fast_only));
  auto g = parse_graph(text, "g.yaml");
  ASSERT_TRUE(g) << g.error().message;
  EXPECT_EQ(g->name, "corridor");
  ASSERT_EQ(g->edges.size(), 1u);
  EXPECT_EQ(g->edges[0].length_m, 4.0);
  EXPECT_EQ(g->edges[0].payload_bytes, 0u);
}

TEST(GraphReaders, ControlBytesInACommentAreLeftToTheFullReader) {
  // Found by fuzz_graph_reader: a canonical graph after a comment line "#\0". yaml-cpp reads
  // a stream opening with "x\0" as UTF-16, so the full reader cannot accept it; the fast reader,
  // which skips comment lines, accepted it. Both must now agree: no graph.
  const std::string canonical = emit_graph(rich_graph());
  for (const std::string& prefix : {std::string("#\0\n", 3), std::string("# \x01\n"), std::string("# \xff\n")}) {
    const std::string text = prefix + canonical;
    EXPECT_FALSE(parse_graph(text, "g.yaml", GraphParser::fast_only)) << "prefix byte " << int(prefix[1]);
  }
  EXPECT_FALSE(parse_graph(std::string("#\0\n", 3) + canonical, "g.yaml"));
  // Printable comments (the writer's own header) stay on the fast path.
  EXPECT_TRUE(parse_graph("# hand note\n" + canonical, "g.yaml", GraphParser::fast_only));
}

TEST(GraphReaders, CrossReferenceErrorsAreTheSameFromBothReaders) {
  Graph g = rich_graph();
  g.edges[1].to = "ghost";
  const std::string text = emit_graph(g);
  auto fast = parse_graph(text, "g.yaml", GraphParser::fast_only);
  auto full = parse_graph(text, "g.yaml", GraphParser::full_only);
  ASSERT_FALSE(fast);
  ASSERT_FALSE(full);
  EXPECT_EQ(fast.error().message, full.error().message);  // content: both readers report the same problem
  EXPECT_EQ(fast.error().where, full.error().where);
  EXPECT_EQ(fast.error().code, visnav::ErrorCode::not_found) << fast.error().message;
  EXPECT_EQ(fast.error().where.file, "g.yaml");
  EXPECT_GT(fast.error().where.line, 0);
}

}  // namespace
}  // namespace visnav
