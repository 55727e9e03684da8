// Place index (issue 21): build from a map's stored descriptors, lookup, verification by
// histogram voting, the file's checksum and staleness checks.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/feature_payloads.hpp"
#include "visnav/map.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/relocalisation/verifier.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::reloc;

namespace {

NodeRecord node(const std::string& name) {
  NodeRecord n;
  n.name = name;
  return n;
}

EdgeRecord edge(const std::string& from, const std::string& to, const std::string& kind, double length_m) {
  EdgeRecord e;
  e.from = from;
  e.to = to;
  e.kind = kind;
  e.length_m = length_m;
  return e;
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("visnav_reloc_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  [[nodiscard]] std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

/// Random binary features: `n` rows of 32 bytes at random positions in a 320x240 image.
Features random_features(std::mt19937& rng, int n) {
  Features f;
  f.descriptors.create(n, 32, CV_8UC1);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<float> u(10.f, 310.f), v(10.f, 230.f);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < 32; ++c) f.descriptors.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(byte(rng));
    f.keypoints.emplace_back(cv::Point2f(u(rng), v(rng)), 7.f, -1.f, 1.f);
  }
  return f;
}

/// A feature_localmaps edge of `places` local maps 0.2 m apart, each with its own random features.
feature_replay::LocalMapPath make_path(std::mt19937& rng, int places, std::vector<Features>& seen) {
  feature_replay::LocalMapPath path;
  for (int i = 0; i < places; ++i) {
    Features f = random_features(rng, 120);
    feature_replay::LocalMap m;
    m.distance_m = 0.2 * i;
    for (const auto& k : f.keypoints) m.positions_px.push_back(k.pt);
    m.descriptors = f.descriptors.clone();
    path.maps.push_back(std::move(m));
    seen.push_back(std::move(f));
  }
  path.length_m = 0.2 * (places - 1);
  path.commands.push_back({0.0, Twist{0.3, 0.0}});
  return path;
}

/// A two-edge map (a -> b -> c) of local-map edges; `seen` gets every place's features in order.
MapStore make_map(const std::string& dir, std::vector<Features>& seen, int places_per_edge = 40) {
  std::mt19937 rng(7);
  auto map = MapStore::create(dir, "reloc test");
  EXPECT_TRUE(map.ok()) << map.error().message;
  map->set_sync(false);
  auto a = map->add_node(node("a"));
  auto b = map->add_node(node("b"));
  auto c = map->add_node(node("c"));
  for (int e = 0; e < 2; ++e) {
    const auto path = make_path(rng, places_per_edge, seen);
    auto id = map->add_edge(edge(e == 0 ? *a : *b, e == 0 ? *b : *c, kLocalMapsKind, path.length_m), path.serialize());
    EXPECT_TRUE(id.ok()) << id.error().message;
  }
  return std::move(*map);
}

PlaceIndexParams small_params() {
  PlaceIndexParams p;
  p.vocabulary_words = 256;
  p.vocabulary_sample = 4000;
  return p;
}

}  // namespace

TEST(PlaceIndex, EveryPlaceFindsItselfFirstFromAPartialView) {
  TempDir tmp;
  std::vector<Features> seen;
  MapStore map = make_map(tmp.str(), seen);
  auto index = build_place_index(map, small_params());
  ASSERT_TRUE(index.ok()) << index.error().message;
  ASSERT_EQ(index->places.size(), 80u);
  ASSERT_EQ(index->edges.size(), 2u);
  std::vector<std::uint64_t> code(static_cast<std::size_t>(index->code_words()));
  std::vector<PlaceCandidate> hits;
  int first = 0;
  for (std::size_t p = 0; p < seen.size(); ++p) {
    // 70 % of the place's features (a partial, shifted view of it).
    cv::Mat part = seen[p].descriptors.rowRange(0, 84);
    ASSERT_TRUE(index->encode(part, code).ok());
    index->query(code, 5, hits);
    ASSERT_EQ(hits.size(), 5u);
    EXPECT_LE(hits[0].hamming, hits[1].hamming);
    if (hits[0].place == p) ++first;
  }
  EXPECT_GE(first, 78) << "a place must be its own nearest code";
}

TEST(PlaceIndex, VerifierVotesForThePlaceWithTheHeadingOffsetOfTheShift) {
  TempDir tmp;
  std::vector<Features> seen;
  MapStore map = make_map(tmp.str(), seen);
  auto index = build_place_index(map, small_params());
  ASSERT_TRUE(index.ok()) << index.error().message;
  feature_replay::HeadingParams heading;  // 60 deg field of view
  PlaceVerifier verifier(*index, map, heading);
  // Place 55 (edge 2, 15 * 0.2 = 3 m) seen with the scene 40 px to the right: the robot is turned left.
  Features current = seen[55];
  for (auto& k : current.keypoints) k.pt.x += 40.f;
  auto votes = verifier.votes(current, 320.0, 8, 0.3);
  ASSERT_TRUE(votes.ok()) << votes.error().message;
  ASSERT_FALSE(votes->empty());
  const PlaceVote& v = votes->front();
  EXPECT_EQ(index->edges[v.edge].id, map.edges()[1].id);
  EXPECT_NEAR(v.distance_m, 3.0, 1e-4);
  const double focal_px = 160.0 / std::tan(30.0 * M_PI / 180.0);
  EXPECT_NEAR(v.heading_offset_rad, std::atan(40.0 / focal_px), 0.02);
  EXPECT_GT(v.heading_offset_rad, 0.0);
  // Random features of no place: nothing verifies.
  std::mt19937 rng(99);
  auto none = verifier.votes(random_features(rng, 120), 320.0, 8, 0.3);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(PlaceIndex, FileRoundTripsAndDamageOrStalenessIsRejectedWithItsCode) {
  TempDir tmp;
  std::vector<Features> seen;
  MapStore map = make_map(tmp.str(), seen, 10);
  auto missing = load_place_index(tmp.str());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::not_found);

  auto index = build_place_index(map, small_params());
  ASSERT_TRUE(index.ok()) << index.error().message;
  ASSERT_TRUE(save_place_index(tmp.str(), *index).ok());
  auto loaded = load_place_index(tmp.str());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->codes, index->codes);
  EXPECT_EQ(loaded->places.size(), index->places.size());
  EXPECT_EQ(cv::norm(loaded->vocabulary, index->vocabulary, cv::NORM_HAMMING), 0.0);
  EXPECT_TRUE(loaded->matches(map).ok());
  EXPECT_TRUE(map.leftover_files().empty()) << "the index is part of the map folder, no temporary file is left";

  // One flipped byte in the body: checksum mismatch, code parse_error, the file named.
  const std::string file = index_path(tmp.str());
  std::vector<char> bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  auto damaged = load_place_index(tmp.str());
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.error().code, ErrorCode::parse_error);
  EXPECT_NE(damaged.error().message.find(file), std::string::npos);
  // Truncated and foreign files too.
  std::ofstream(file, std::ios::binary).write(bytes.data(), 10);
  EXPECT_EQ(load_place_index(tmp.str()).error().code, ErrorCode::parse_error);
  std::ofstream(file, std::ios::binary) << "not an index at all, just text that is long enough";
  EXPECT_EQ(load_place_index(tmp.str()).error().code, ErrorCode::parse_error);

  // A map taught further after the index was built: stale, code inconsistent.
  std::mt19937 rng(3);
  std::vector<Features> more;
  const auto path = make_path(rng, 5, more);
  auto c = map.find_node_by_name("c");
  ASSERT_NE(c, nullptr);
  auto d = map.add_node(node("d"));
  ASSERT_TRUE(d.ok());
  ASSERT_TRUE(map.add_edge(edge(c->id, *d, kLocalMapsKind, path.length_m), path.serialize()).ok());
  const Status stale = index->matches(map);
  ASSERT_FALSE(stale.ok());
  EXPECT_EQ(stale.error().code, ErrorCode::inconsistent);
}

TEST(PlaceIndex, MapWithoutFeatureEdgesOrWithFloatDescriptorsIsRefused) {
  TempDir tmp;
  auto map = MapStore::create(tmp.str(), "no features");
  ASSERT_TRUE(map.ok());
  map->set_sync(false);
  auto a = map->add_node(node("a"));
  auto b = map->add_node(node("b"));
  ASSERT_TRUE(map->add_edge(edge(*a, *b, "path_following", 3.0), path_payload::PathPayload{}.encode()).ok());
  auto none = build_place_index(*map, small_params());
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::not_found);

  feature_replay::LocalMapPath path;
  feature_replay::LocalMap m;
  m.descriptors = cv::Mat::ones(300, 16, CV_32FC1);
  m.positions_px.assign(300, cv::Point2f(5.f, 5.f));
  path.maps.push_back(m);
  ASSERT_TRUE(map->add_edge(edge(*b, *a, kLocalMapsKind, 0.0), path.serialize()).ok());
  auto floats = build_place_index(*map, small_params());
  ASSERT_FALSE(floats.ok());
  EXPECT_EQ(floats.error().code, ErrorCode::invalid_value);
}
