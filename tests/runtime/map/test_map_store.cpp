// MapStore: round trip, ids, statistics, bytes per metre, batching, leftovers, large maps.
#include <unistd.h>

#include <cmath>

#include "map_test_util.hpp"

namespace visnav {
namespace {

using test::edge;
using test::make_body;
using test::node;
using test::TempDir;

TEST(MapStore, RoundTripKeepsEveryFieldAndPayload) {
  TempDir tmp;
  const std::string dir = tmp / "campus";
  const auto body_a = make_body(5000, 1);
  const auto body_b = make_body(17, 2);
  const std::vector<std::uint8_t> body_c;  // empty payload is allowed
  {
    auto map = MapStore::create(dir, "campus: \"main\" route");
    ASSERT_TRUE(map) << map.error().message;
    NodeRecord start = node("start", "lab door");
    start.position_hint = Pose2D{1.5, -2.25, 0.1};
    ASSERT_TRUE(map->add_node(start));
    ASSERT_TRUE(map->add_node(node("corner", "corridor\tcorner")));
    ASSERT_TRUE(map->add_node(node("park", "")));
    EdgeRecord e1 = edge("start", "corner", "feature_segment", 12.345678901234567, 0.1);
    e1.id = "e-lab";
    e1.created = "2026-11-22T08:40:00Z";
    e1.statistics = {{"landmarks", 812}, {"traversals", 0}, {"mean.response", 1e-7}};
    ASSERT_TRUE(map->add_edge(e1, body_a));
    auto e2 = map->add_edge(edge("corner", "park", "path_following", 40.0, M_PI / 2), body_b);
    ASSERT_TRUE(e2) << e2.error().message;
    EXPECT_EQ(*e2, "e1");  // assigned: the map already has one edge
    ASSERT_TRUE(map->add_edge(edge("park", "start", "visual_memory", 0.0, -3.0, "loop"), body_c));
  }
  auto map = MapStore::open(dir);
  ASSERT_TRUE(map) << map.error().message;
  EXPECT_EQ(map->name(), "campus: \"main\" route");
  ASSERT_EQ(map->nodes().size(), 3u);
  ASSERT_EQ(map->edges().size(), 3u);
  const auto* start = map->find_node("start");
  ASSERT_NE(start, nullptr);
  EXPECT_EQ(start->name, "lab door");
  ASSERT_TRUE(start->position_hint.has_value());
  EXPECT_EQ(start->position_hint->x_m, 1.5);
  EXPECT_EQ(start->position_hint->y_m, -2.25);
  EXPECT_EQ(start->position_hint->heading_rad, 0.1);
  EXPECT_EQ(map->find_node("corner")->name, "corridor\tcorner");
  EXPECT_FALSE(map->find_node("corner")->position_hint.has_value());
  EXPECT_EQ(map->find_node_by_name("lab door"), start);

  const auto* e = map->find_edge("e-lab");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->from, "start");
  EXPECT_EQ(e->to, "corner");
  EXPECT_EQ(e->kind, "feature_segment");
  EXPECT_EQ(e->length_m, 12.345678901234567);  // exact: doubles round-trip
  EXPECT_EQ(e->azimuth_rad, 0.1);
  EXPECT_EQ(e->created, "2026-11-22T08:40:00Z");
  EXPECT_EQ(e->statistics.at("landmarks"), 812);
  EXPECT_EQ(e->statistics.at("mean.response"), 1e-7);
  EXPECT_EQ(e->payload_file, "edges/e-lab.bin");
  EXPECT_EQ(e->payload_bytes, map_format::kPayloadFixedHeaderBytes + 15 + 5 + body_a.size());
  EXPECT_FALSE(map->find_edge("e1")->created.empty());

  auto a = map->read_payload("e-lab");
  ASSERT_TRUE(a) << a.error().message;
  EXPECT_EQ(*a, body_a);
  auto b = map->read_payload("e1");
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_EQ(*b, body_b);
  auto c = map->read_payload("loop");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_TRUE(c->empty());

  const auto az = map->outgoing_azimuths("corner");
  ASSERT_EQ(az.size(), 1u);
  EXPECT_EQ(az[0].edge_id, "e1");
  EXPECT_EQ(az[0].azimuth_rad, M_PI / 2);
  EXPECT_EQ(map->outgoing("start").size(), 1u);
  EXPECT_EQ(map->incoming("start").size(), 1u);
  EXPECT_EQ(map->incoming("start")[0]->id, "loop");
  EXPECT_TRUE(map->validate().empty());
  EXPECT_TRUE(map->leftover_files().empty());

  // The graph file is human-readable and lists the node azimuths.
  const std::string text = test::read_text(map->graph_path());
  EXPECT_NE(text.find("format: visnav-map"), std::string::npos);
  EXPECT_NE(text.find("{edge: \"e1\", azimuth_rad: 1.5707963267948966}"), std::string::npos) << text;
  EXPECT_NE(text.find("kind: \"path_following\""), std::string::npos);
}

TEST(MapStore, AssignsIdsAndRejectsBadRecordsWithoutChangingTheMap) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "m", "m");
  ASSERT_TRUE(map);
  EXPECT_EQ(*map->add_node({}), "n0");
  EXPECT_EQ(*map->add_node({}), "n1");
  auto dup = map->add_node(node("n1"));
  ASSERT_FALSE(dup);
  EXPECT_EQ(dup.error().code, visnav::ErrorCode::inconsistent) << dup.error().message;
  EXPECT_FALSE(map->add_node(node("bad id/../x")));
  EXPECT_FALSE(map->add_node(node("x", "co\xff\xffrridor")));  // YAML cannot carry invalid UTF-8
  EXPECT_TRUE(map->add_node(node("y", "chodba \xc5\xa1\xc3\xad\xc5\x99ka")));  // valid UTF-8 is fine
  const auto body = make_body(10, 3);
  EXPECT_TRUE(map->add_edge(edge("n0", "n1", "feature_segment", 1.0, 0.0, "a"), body));
  auto r = map->add_edge(edge("n0", "n1", "feature_segment", 1.0, 0.0, "a"), body);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, visnav::ErrorCode::inconsistent) << r.error().message;
  r = map->add_edge(edge("n0", "nowhere", "feature_segment", 1.0), body);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, visnav::ErrorCode::not_found) << r.error().message;
  EXPECT_NE(r.error().message.find("nowhere"), std::string::npos);  // names the missing node
  EXPECT_FALSE(map->add_edge(edge("n0", "n1", "bad kind!", 1.0), body));
  EXPECT_FALSE(map->add_edge(edge("n0", "n1", "feature_segment", std::nan("")), body));
  EXPECT_FALSE(map->add_edge(edge("n0", "n1", "feature_segment", -1.0), body));
  EXPECT_FALSE(map->add_edge(edge("n0", "n1", "feature_segment", 1.0, INFINITY), body));
  EdgeRecord bad_time = edge("n0", "n1", "feature_segment", 1.0);
  bad_time.created = "yesterday";
  EXPECT_FALSE(map->add_edge(bad_time, body));
  EXPECT_EQ(map->edges().size(), 1u);
  auto reopened = MapStore::open(tmp / "m");
  ASSERT_TRUE(reopened);
  EXPECT_EQ(reopened->edges().size(), 1u);
  EXPECT_EQ(reopened->nodes().size(), 3u);
  EXPECT_EQ(reopened->find_node("y")->name, "chodba \xc5\xa1\xc3\xad\xc5\x99ka");
}

TEST(MapStore, NodeNamesResolveToTheFirstNodeOfThatNameBeforeAndAfterReopening) {
  // find_node_by_name uses an index (bench/replay: O(1) on a 10 km map); an id wins over a name.
  // Non-empty names are unique (issue 17); empty names repeat and resolve to the first node.
  TempDir tmp;
  {
    auto map = MapStore::create(tmp / "m", "m");
    ASSERT_TRUE(map);
    ASSERT_TRUE(map->add_node(node("a", "door")));
    EXPECT_FALSE(map->add_node(node("b", "door")));  // a second "door" is refused
    ASSERT_TRUE(map->add_node(node("c", "a")));  // named like node a's id
    ASSERT_TRUE(map->add_node(node("d")));       // empty name
    ASSERT_TRUE(map->add_node(node("e")));
    EXPECT_EQ(map->find_node_by_name("door")->id, "a");
    EXPECT_EQ(map->find_node_by_name("")->id, "d");
    EXPECT_EQ(map->find_node_by_name("nowhere"), nullptr);
    EXPECT_EQ((*map->resolve_node("a"))->id, "a");
    EXPECT_FALSE(map->add_node(node("f", "co\xff\xffrridor")));  // rejected: no trace in the index
    EXPECT_EQ(map->find_node_by_name("co\xff\xffrridor"), nullptr);
  }
  auto map = MapStore::open(tmp / "m");
  ASSERT_TRUE(map);
  EXPECT_EQ(map->find_node_by_name("door")->id, "a");
  EXPECT_EQ(map->find_node_by_name("a")->id, "c");
  EXPECT_EQ(map->find_node_by_name("")->id, "d");
  EXPECT_EQ((*map->resolve_node("door"))->id, "a");
  EXPECT_FALSE(map->resolve_node("nowhere"));
}

TEST(MapStore, CreateRefusesAnExistingMapAndOpenExplainsMissingOnes) {
  TempDir tmp;
  ASSERT_TRUE(MapStore::create(tmp / "m", "m"));
  auto again = MapStore::create(tmp / "m", "m");
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().code, visnav::ErrorCode::inconsistent) << again.error().message;
  auto missing = MapStore::open(tmp / "nothing");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, visnav::ErrorCode::not_found) << missing.error().message;
  EXPECT_NE(missing.error().message.find("nothing"), std::string::npos);  // names the folder
  std::filesystem::create_directories(tmp / "empty");
  auto empty = MapStore::open(tmp / "empty");
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().code, visnav::ErrorCode::not_found) << empty.error().message;
}

TEST(MapStore, BytesPerMetrePerKind) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "m", "m");
  ASSERT_TRUE(map);
  for (const char* n : {"a", "b", "c"}) ASSERT_TRUE(map->add_node(node(n)));
  ASSERT_TRUE(map->add_edge(edge("a", "b", "feature_segment", 10.0), make_body(100000, 1)));
  ASSERT_TRUE(map->add_edge(edge("b", "c", "feature_segment", 10.0), make_body(100000, 2)));
  ASSERT_TRUE(map->add_edge(edge("c", "a", "path_following", 40.0), make_body(2000, 3)));
  const MapStats s = map->stats();
  EXPECT_EQ(s.nodes, 3u);
  EXPECT_EQ(s.total.edges, 3u);
  EXPECT_DOUBLE_EQ(s.total.length_m, 60.0);
  const auto header = [](std::size_t kind, std::size_t id) { return map_format::kPayloadFixedHeaderBytes + kind + id; };
  const auto& f = s.per_kind.at("feature_segment");
  EXPECT_EQ(f.edges, 2u);
  EXPECT_EQ(f.payload_bytes, 2 * (100000 + header(15, 2)));
  EXPECT_DOUBLE_EQ(f.bytes_per_m(), (200000.0 + 2 * header(15, 2)) / 20.0);
  const auto& p = s.per_kind.at("path_following");
  EXPECT_DOUBLE_EQ(p.bytes_per_m(), (2000.0 + header(14, 2)) / 40.0);
  EXPECT_LT(p.bytes_per_m(), f.bytes_per_m() / 50.0);
  // Recorded sizes equal the files on disk.
  for (const auto& e : map->edges()) {
    EXPECT_EQ(std::filesystem::file_size(tmp / ("m/" + e.payload_file)), e.payload_bytes);
  }
  EXPECT_EQ(KindStats{}.bytes_per_m(), 0.0);
}

TEST(MapStore, EdgeStatisticsPersist) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "m", "m");
  ASSERT_TRUE(map);
  ASSERT_TRUE(map->add_node(node("a")));
  ASSERT_TRUE(map->add_edge(edge("a", "a", "feature_segment", 3.0, 0.0, "e"), make_body(5, 1)));
  ASSERT_TRUE(map->set_edge_statistic("e", "traversals", 4));
  EXPECT_FALSE(map->set_edge_statistic("e", "bad key", 1));
  EXPECT_FALSE(map->set_edge_statistic("missing", "traversals", 1));
  auto reopened = MapStore::open(tmp / "m");
  ASSERT_TRUE(reopened);
  EXPECT_EQ(reopened->find_edge("e")->statistics.at("traversals"), 4.0);
}

TEST(MapStore, BatchedGraphWritesNeedFlush) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "m", "m");
  ASSERT_TRUE(map);
  map->set_autoflush(false);
  ASSERT_TRUE(map->add_node(node("a")));
  ASSERT_TRUE(map->add_edge(edge("a", "a", "feature_segment", 1.0, 0.0, "e"), make_body(5, 1)));
  EXPECT_TRUE(std::filesystem::exists(tmp / "m/edges/e.bin"));  // payloads are written at once
  EXPECT_EQ(MapStore::open(tmp / "m")->edges().size(), 0u);
  const auto problems = map->validate();
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("flush"), std::string::npos);
  ASSERT_TRUE(map->flush());
  EXPECT_EQ(MapStore::open(tmp / "m")->edges().size(), 1u);
  EXPECT_TRUE(map->validate().empty());
}

TEST(MapStore, LeftoverFilesAreListedButNeverTakenForEdges) {
  TempDir tmp;
  {
    auto map = MapStore::create(tmp / "m", "m");
    ASSERT_TRUE(map);
    ASSERT_TRUE(map->add_node(node("a")));
    ASSERT_TRUE(map->add_edge(edge("a", "a", "feature_segment", 1.0, 0.0, "e0"), make_body(50, 1)));
  }
  // What an interrupted write can leave: a half-written temporary payload, a temporary graph,
  // and a complete payload whose graph update never happened.
  // Their writer is still running here (the parent process): open() leaves them in place (it
  // deletes only those of dead writers, tested in tests/integration/security).
  const std::string live = std::to_string(::getppid());
  test::write_bytes(tmp / ("m/edges/.e1.bin.tmp." + live), make_body(20, 9));
  test::write_text(tmp / ("m/.graph.yaml.tmp." + live), "format: visnav-map\nversion: 1\nname: x\nno");
  auto orphan = map_format::encode_payload("feature_segment", "e1", make_body(50, 2));
  test::write_bytes(tmp / "m/edges/e1.bin", orphan);
  auto map = MapStore::open(tmp / "m");
  ASSERT_TRUE(map) << map.error().message;
  EXPECT_EQ(map->edges().size(), 1u);
  EXPECT_TRUE(map->validate().empty());
  const auto left = map->leftover_files();
  ASSERT_EQ(left.size(), 3u);
  EXPECT_NE(left[0].find(".graph.yaml.tmp." + live), std::string::npos);
  // The next edge reuses the orphan's id and replaces its file.
  auto id = map->add_edge(edge("a", "a", "path_following", 2.0), make_body(30, 3));
  ASSERT_TRUE(id);
  EXPECT_EQ(*id, "e1");
  EXPECT_EQ(*map->read_payload("e1"), make_body(30, 3));
}

TEST(MapStore, LargeGeneratedMapOpensCompleteAndCorrect) {
  // Correctness of a big map; the open-time figure lives in bench_map.
  TempDir tmp;
  constexpr int kEdges = 2000;
  {
    auto map = MapStore::create(tmp / "big", "big");
    ASSERT_TRUE(map);
    map->set_autoflush(false);
    map->set_sync(false);
    for (int i = 0; i <= kEdges; ++i) ASSERT_TRUE(map->add_node({}));
    for (int i = 0; i < kEdges; ++i) {
      EdgeRecord e = edge(test::numbered("n", i), test::numbered("n", i + 1), i % 3 == 0 ? "path_following" : "feature_segment",
                          5.0, 0.001 * i);
      e.statistics["landmarks"] = i;
      ASSERT_TRUE(map->add_edge(e, make_body(64, static_cast<std::uint32_t>(i))));
    }
    ASSERT_TRUE(map->flush());
  }
  auto map = MapStore::open(tmp / "big");
  ASSERT_TRUE(map) << map.error().message;
  ASSERT_EQ(map->edges().size(), static_cast<std::size_t>(kEdges));
  EXPECT_DOUBLE_EQ(map->stats().total.length_m, 5.0 * kEdges);
  EXPECT_EQ(map->find_edge("e1234")->statistics.at("landmarks"), 1234.0);
  EXPECT_EQ(map->find_edge("e1234")->azimuth_rad, 0.001 * 1234);
  EXPECT_EQ(*map->read_payload("e1999"), make_body(64, 1999));
  auto route = plan_route(*map, "n0", "n2000");
  ASSERT_TRUE(route) << route.error().message;
  EXPECT_EQ(route->edge_ids.size(), static_cast<std::size_t>(kEdges));
  EXPECT_EQ(route->edge_ids.back(), "e1999");
}

TEST(PayloadWriterReader, RoundTripAndBoundsChecks) {
  PayloadWriter w;
  w.put<std::uint32_t>(0xDEADBEEF);
  w.put<double>(-1.25);
  w.put_string("orb");
  w.put<std::int16_t>(-7);
  const auto bytes = w.bytes();
  EXPECT_EQ(bytes[0], 0xEF);  // little-endian
  PayloadReader r(bytes);
  EXPECT_EQ(*r.get<std::uint32_t>(), 0xDEADBEEFu);
  EXPECT_EQ(*r.get<double>(), -1.25);
  EXPECT_EQ(*r.get_string(), "orb");
  EXPECT_EQ(*r.get<std::int16_t>(), -7);
  EXPECT_TRUE(r.at_end());
  auto past = r.get<std::uint8_t>();
  ASSERT_FALSE(past);
  EXPECT_EQ(past.error().code, visnav::ErrorCode::parse_error) << past.error().message;

  PayloadWriter lying;
  lying.put<std::uint64_t>(1u << 30);  // claims a 1 GiB block
  lying.put<std::uint8_t>(1);
  PayloadReader lr(lying.bytes());
  auto block = lr.get_bytes();
  ASSERT_FALSE(block);
  EXPECT_EQ(block.error().code, visnav::ErrorCode::parse_error) << block.error().message;
}

TEST(MapFormat, Crc32MatchesTheStandardCheckValue) {
  const std::string s = "123456789";
  EXPECT_EQ(map_format::crc32({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}), 0xCBF43926u);
  const auto body = make_body(1000, 5);
  const auto whole = map_format::crc32(body);
  const auto chained = map_format::crc32(std::span(body).subspan(333), map_format::crc32(std::span(body).first(333)));
  EXPECT_EQ(whole, chained);
}

}  // namespace
}  // namespace visnav
