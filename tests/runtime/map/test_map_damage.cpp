// Damaged files: truncated, bit-flipped, foreign, wrong-version payloads and graph files give a
// clear error naming the file (and line for the graph) — never a crash.
#include <random>

#include "map/graph_io.hpp"
#include "map_test_util.hpp"

namespace visnav {
namespace {

using test::edge;
using test::make_body;
using test::node;
using test::TempDir;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class DamagedMap : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_ / "m";
    auto map = MapStore::create(dir_, "damage");
    ASSERT_TRUE(map);
    map->set_sync(false);  // durability is test_map_crash's subject; keep this fast
    ASSERT_TRUE(map->add_node(node("a", "start")));
    ASSERT_TRUE(map->add_node(node("b", "end")));
    ASSERT_TRUE(map->add_edge(edge("a", "b", "feature_segment", 10.0, 0.5, "e0"), make_body(300, 1)));
    ASSERT_TRUE(map->add_edge(edge("b", "a", "path_following", 10.0, -2.6, "e1"), make_body(200, 2)));
    payload_ = dir_ + "/edges/e0.bin";
    graph_ = dir_ + "/graph.yaml";
  }

  /// Opens the map (must succeed: payload damage is found lazily) and returns read_payload's error
  /// for e0, after checking validate() reports exactly that problem.
  std::string payload_error() {
    auto map = MapStore::open(dir_);
    EXPECT_TRUE(map) << map.error().message;
    if (!map) return {};
    auto r = map->read_payload("e0");
    EXPECT_FALSE(r);
    if (r) return {};
    const std::string message = r.error().message;
    EXPECT_TRUE(contains(message, payload_)) << "error must name the file: " << message;
    const auto problems = map->validate();
    EXPECT_EQ(problems.size(), 1u);
    if (!problems.empty()) {
      EXPECT_EQ(problems[0], message);
    }
    EXPECT_TRUE(map->read_payload("e1")) << "the undamaged edge must still read";
    return message;
  }

  /// Open must fail with an error located in graph.yaml; returns it.
  Error graph_failure() {
    auto map = MapStore::open(dir_);
    EXPECT_FALSE(map) << "damaged graph was accepted";
    if (map) return {};
    EXPECT_EQ(map.error().where.file, graph_) << "error must be located in the graph file: " << map.error().message;
    return map.error();
  }
  /// The code and line of graph_failure(), for comparing at once.
  std::pair<ErrorCode, int> graph_code_line() {
    const Error e = graph_failure();
    return {e.code, e.where.line};
  }

  void replace_in_graph(const std::string& from, const std::string& to) {
    std::string text = test::read_text(graph_);
    const auto pos = text.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
    test::write_text(graph_, text);
  }

  TempDir tmp_;
  std::string dir_, payload_, graph_;
};

TEST_F(DamagedMap, TruncatedPayload) {
  auto bytes = test::read_bytes(payload_);
  bytes.resize(bytes.size() / 2);
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "truncated")) << payload_error();
  bytes.resize(20);  // inside the fixed header
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "truncated"));
  test::write_bytes(payload_, {});
  EXPECT_TRUE(contains(payload_error(), "empty file"));
}

TEST_F(DamagedMap, BitFlippedPayloadBodyAndHeader) {
  const auto original = test::read_bytes(payload_);
  auto bytes = original;
  bytes[bytes.size() - 10] ^= 0x04;
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "damaged body: checksum mismatch"));
  bytes = original;
  bytes[33] ^= 0x01;  // inside the kind string
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "header checksum mismatch"));
}

TEST_F(DamagedMap, EverySingleBitFlipIsDetected) {
  const auto original = test::read_bytes(payload_);
  ASSERT_TRUE(map_format::parse_payload(original, payload_));
  // Exhaustively in memory (the parser the store uses), then a sample through the files.
  for (std::size_t i = 0; i < original.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      auto bytes = original;
      bytes[i] ^= static_cast<std::uint8_t>(1U << bit);
      auto r = map_format::parse_payload(bytes, payload_);
      ASSERT_FALSE(r) << "flip of bit " << bit << " in byte " << i << " went unnoticed";
      ASSERT_EQ(r.error().message.rfind(payload_ + ": ", 0), 0u) << r.error().message;
    }
  }
  auto map = MapStore::open(dir_);
  ASSERT_TRUE(map);
  for (std::size_t i = 0; i < original.size(); i += 37) {
    auto bytes = original;
    bytes[i] ^= 0x20;
    test::write_bytes(payload_, bytes);
    auto r = map->read_payload("e0");
    ASSERT_FALSE(r) << "flip in byte " << i << " went unnoticed";
    ASSERT_TRUE(contains(r.error().message, payload_)) << r.error().message;
  }
}

TEST_F(DamagedMap, ForeignPayloads) {
  test::write_text(payload_, "\x89PNG\r\n\x1a\n this is an image, not an edge");
  EXPECT_TRUE(contains(payload_error(), "not a visnav edge payload"));
  test::write_text(payload_, "VNAV");  // a prefix of the magic
  EXPECT_TRUE(contains(payload_error(), "truncated"));
  // A valid payload of another edge copied over this one.
  test::write_bytes(payload_, test::read_bytes(dir_ + "/edges/e1.bin"));
  EXPECT_TRUE(contains(payload_error(), "foreign payload: it belongs to edge 'e1'"));
  // Right id, wrong kind.
  test::write_bytes(payload_, map_format::encode_payload("visual_memory", "e0", make_body(300, 1)));
  EXPECT_TRUE(contains(payload_error(), "kind 'visual_memory'"));
  // A huge foreign file is refused before it is read into memory.
  test::write_bytes(payload_, std::vector<std::uint8_t>(3u << 20, 0));
  const std::string huge = payload_error();
  EXPECT_TRUE(contains(huge, "larger than expected")) << huge;
  // Trailing garbage after a valid file.
  auto bytes = map_format::encode_payload("feature_segment", "e0", make_body(300, 1));
  bytes.push_back(0);
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "trailing data"));
}

TEST_F(DamagedMap, PayloadFromANewerFormatVersion) {
  auto bytes = map_format::encode_payload("feature_segment", "e0", make_body(300, 1));
  bytes[8] = 2;  // version 2, with a consistent header checksum
  std::uint32_t crc = map_format::crc32(std::span(bytes).first(28));
  crc = map_format::crc32(std::span(bytes).subspan(32, 15 + 2), crc);
  for (int i = 0; i < 4; ++i) bytes[28 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  test::write_bytes(payload_, bytes);
  EXPECT_TRUE(contains(payload_error(), "unsupported payload format version 2"));
}

TEST_F(DamagedMap, MissingPayload) {
  std::filesystem::remove(payload_);
  EXPECT_TRUE(contains(payload_error(), "cannot open"));
}

TEST_F(DamagedMap, GraphSyntaxErrorNamesFileAndLine) {
  replace_in_graph("name: \"start\"", "name: [\"start\"");
  const Error e = graph_failure();
  EXPECT_EQ(e.code, ErrorCode::parse_error) << e.message;
  EXPECT_GT(e.where.line, 3) << e.message;  // a line inside the file
}

TEST_F(DamagedMap, GraphWrongTypesAndUnknownKeysNameTheLine) {
  const std::string text = test::read_text(graph_);
  const auto line_of = [&](const std::string& needle) {
    const auto pos = text.find(needle);
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
  };
  const int line = line_of("length_m: 10");
  replace_in_graph("length_m: 10", "length_m: ten");
  EXPECT_EQ(graph_code_line(), std::make_pair(ErrorCode::parse_error, line));
  replace_in_graph("length_m: ten", "lenght_m: 10");
  EXPECT_EQ(graph_code_line(), std::make_pair(ErrorCode::unknown_key, line));
}

TEST_F(DamagedMap, GraphDanglingReferences) {
  replace_in_graph("to: \"b\"", "to: \"zzz\"");
  EXPECT_EQ(graph_failure().code, ErrorCode::not_found);
}

TEST_F(DamagedMap, GraphOutgoingListsUnknownEdge) {
  replace_in_graph("{edge: \"e0\"", "{edge: \"e9\"");
  EXPECT_EQ(graph_failure().code, ErrorCode::not_found);
}

TEST_F(DamagedMap, GraphDuplicateIds) {
  replace_in_graph("id: \"b\"", "id: \"a\"");
  EXPECT_EQ(graph_failure().code, ErrorCode::inconsistent);
}

TEST_F(DamagedMap, GraphDuplicateEdgeIds) {
  std::string text = test::read_text(graph_);
  // Rename e1 to e0 everywhere (its payload line too): the second e0 is a duplicate.
  for (auto pos = text.find("e1"); pos != std::string::npos; pos = text.find("e1")) text.replace(pos, 2, "e0");
  test::write_text(graph_, text);
  EXPECT_EQ(graph_failure().code, ErrorCode::inconsistent);
}

TEST_F(DamagedMap, GraphFromANewerVersionOrForeignFile) {
  replace_in_graph("version: 1", "version: 7");
  EXPECT_EQ(graph_failure().code, ErrorCode::out_of_range);
  test::write_text(graph_, "robot:\n  type: sim\n  max_speed_mps: 1.0\n");
  EXPECT_EQ(graph_code_line(), std::make_pair(ErrorCode::unknown_key, 1));
  test::write_text(graph_, "");
  EXPECT_EQ(graph_failure().code, ErrorCode::parse_error);
  test::write_bytes(graph_, make_body(500, 77));  // binary junk
  graph_failure();
  test::write_text(graph_, "format: visnav-map\nversion: 1\nname: x\nnodes: []\n");
  EXPECT_EQ(graph_failure().code, ErrorCode::missing);
}

TEST_F(DamagedMap, PayloadPathEscapingTheMapIsRejected) {
  replace_in_graph("payload: \"edges/e0.bin\"", "payload: \"../../etc/passwd\"");
  EXPECT_EQ(graph_failure().code, ErrorCode::parse_error);
}

TEST_F(DamagedMap, EveryTruncationOfTheGraphFailsCleanly) {
  const std::string text = test::read_text(graph_);
  // Every prefix through the parser the store uses (in memory: fast) ...
  for (std::size_t n = 0; n + 1 < text.size(); ++n) {
    auto g = map_detail::parse_graph(text.substr(0, n), graph_);
    if (g) {
      // A cut at a record boundary can leave a smaller valid graph.
      EXPECT_LE(g->edges.size(), 2u) << "cut at " << n;
    } else {
      ASSERT_EQ(g.error().where.file, graph_) << "cut at " << n << ": " << g.error().message;
    }
  }
  // ... and a sample through the files, where validate() must also behave.
  for (std::size_t n = 0; n + 1 < text.size(); n += 61) {
    test::write_text(graph_, text.substr(0, n));
    auto map = MapStore::open(dir_);
    if (map) {
      for (const auto& problem : map->validate()) EXPECT_TRUE(contains(problem, dir_)) << problem;
    } else {
      ASSERT_EQ(map.error().where.file, graph_) << "cut at " << n << ": " << map.error().message;
    }
  }
}

TEST_F(DamagedMap, RandomBitFlipsInTheGraphNeverCrash) {
  const std::string text = test::read_text(graph_);
  std::mt19937 rng(12345);
  int rejected = 0;
  constexpr int kTrials = 3000;
  for (int trial = 0; trial < kTrials; ++trial) {
    std::string damaged = text;
    for (int k = 0; k < 1 + trial % 3; ++k) damaged[rng() % damaged.size()] ^= static_cast<char>(1U << (rng() % 8));
    auto g = map_detail::parse_graph(damaged, graph_);
    if (!g) {
      ++rejected;
      ASSERT_EQ(g.error().where.file, graph_) << g.error().message;
    } else if (trial % 100 == 0) {
      // An accepted damaged graph (e.g. a changed name) goes through the store and validate().
      test::write_text(graph_, damaged);
      auto map = MapStore::open(dir_);
      ASSERT_TRUE(map) << map.error().message;
      (void)map->validate();
    }
  }
  EXPECT_GT(rejected, kTrials / 2);
}

}  // namespace
}  // namespace visnav
