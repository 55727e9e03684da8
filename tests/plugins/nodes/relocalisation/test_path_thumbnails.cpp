// path_following places (issue 21): the path payload codec (VPF1 still read, VPF2 with
// thumbnails), thumbnail comparison, thumbnail places in the index and their votes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/feature_payloads.hpp"
#include "visnav/map.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/relocalisation/verifier.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::reloc;
using visnav::path_payload::PathPayload;

namespace {

/// A BGR 320x240 view of its own: smooth blobs of grey (what distant scenery looks like at 64x24).
cv::Mat view(int seed) {
  cv::Mat noise(12, 16, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat grey, bgr;
  cv::resize(noise, grey, cv::Size(320, 240), 0, 0, cv::INTER_CUBIC);
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// `image` with its content moved `dx_px` to the right (the camera turned left).
cv::Mat shifted(const cv::Mat& image, double dx_px) {
  cv::Mat out;
  cv::warpAffine(image, out, cv::Matx23d(1, 0, dx_px, 0, 1, 0), image.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

PathPayload payload_of(int first_seed, int count) {
  PathPayload p;
  path_payload::ColourModelData m;
  m.mean = {10.0, -5.0, 120.0};
  m.cov = {4, 0, 0, 0, 4, 0, 0, 0, 9};
  p.models.push_back(m);
  for (int k = 0; k < count; ++k) {
    auto t = path_payload::make_thumbnail(view(first_seed + k));
    EXPECT_TRUE(t.ok());
    p.thumbnails.push_back({0.5 * k, *t});
  }
  return p;
}

/// A VPF1 body as the path teacher wrote it before thumbnails: magic, count, 12 doubles.
std::vector<std::uint8_t> vpf1_body() {
  PayloadWriter w;
  w.put<std::uint32_t>(path_payload::kMagicV1);
  w.put<std::uint32_t>(1);
  for (int i = 0; i < 12; ++i) w.put<double>(i == 3 || i == 7 || i == 11 ? 4.0 : 1.0);
  return w.take();
}

}  // namespace

TEST(PathPayload, RoundTripsThumbnailsAndStillReadsVersion1) {
  PathPayload p = payload_of(1, 4);
  p.offsets = {{0.0, 0.25, 0.2}, {0.4, -0.125, -0.1}, {0.4, 0.5, 0.45}};
  auto back = PathPayload::decode(p.encode());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->version, 3u);
  ASSERT_EQ(back->offsets.size(), 3u);
  EXPECT_DOUBLE_EQ(back->offsets[1].distance_m, 0.4);
  EXPECT_DOUBLE_EQ(back->offsets[1].offset, -0.125);
  EXPECT_DOUBLE_EQ(back->offsets[2].junction_offset, 0.45);
  ASSERT_EQ(back->models.size(), 1u);
  EXPECT_DOUBLE_EQ(back->models[0].mean[2], 120.0);
  EXPECT_DOUBLE_EQ(back->models[0].cov[8], 9.0);
  ASSERT_EQ(back->thumbnails.size(), 4u);
  EXPECT_DOUBLE_EQ(back->thumbnails[3].distance_m, 1.5);
  EXPECT_EQ(back->thumbnails[2].image.size(), cv::Size(path_payload::kThumbnailWidthPx, path_payload::kThumbnailHeightPx));
  EXPECT_EQ(cv::norm(back->thumbnails[2].image, p.thumbnails[2].image, cv::NORM_INF), 0.0);

  // A VPF2 body (as taught before session 12): the VPF3 one without the offset profile.
  std::vector<std::uint8_t> v2 = payload_of(1, 4).encode();
  v2.resize(v2.size() - 4);  // the empty profile's count
  const std::uint32_t magic2 = path_payload::kMagicV2;
  std::memcpy(v2.data(), &magic2, 4);
  auto two = PathPayload::decode(v2);
  ASSERT_TRUE(two.ok()) << two.error().message;
  EXPECT_EQ(two->version, 2u);
  EXPECT_EQ(two->thumbnails.size(), 4u);
  EXPECT_TRUE(two->offsets.empty());

  auto old = PathPayload::decode(vpf1_body());
  ASSERT_TRUE(old.ok()) << old.error().message;
  EXPECT_EQ(old->version, 1u);
  EXPECT_EQ(old->models.size(), 1u);
  EXPECT_TRUE(old->thumbnails.empty());
}

TEST(PathPayload, DamagedBodiesAreParseErrorsNotCrashes) {
  const std::vector<std::uint8_t> good = payload_of(1, 3).encode();
  for (std::size_t cut : {std::size_t{3}, std::size_t{20}, good.size() - 1}) {
    auto r = PathPayload::decode(std::span(good).first(cut));
    ASSERT_FALSE(r.ok()) << cut;
    EXPECT_EQ(r.error().code, ErrorCode::parse_error);
  }
  std::vector<std::uint8_t> bad_magic = good;
  bad_magic[0] ^= 0xff;
  EXPECT_EQ(PathPayload::decode(bad_magic).error().code, ErrorCode::parse_error);
  // Offset samples out of order or out of [-1, 1].
  PathPayload unordered = payload_of(1, 3);
  unordered.offsets = {{1.0, 0.1, 0.1}, {0.5, 0.1, 0.1}};
  EXPECT_EQ(PathPayload::decode(unordered.encode()).error().code, ErrorCode::parse_error);
  PathPayload too_far = payload_of(1, 3);
  too_far.offsets = {{1.0, 1.5, 0.1}};
  EXPECT_EQ(PathPayload::decode(too_far.encode()).error().code, ErrorCode::parse_error);
  std::vector<std::uint8_t> trailing = vpf1_body();
  trailing.push_back(0);
  EXPECT_EQ(PathPayload::decode(trailing).error().code, ErrorCode::parse_error);
}

TEST(Thumbnail, CorrelationFindsTheShiftAndIgnoresBrightness) {
  const cv::Mat a = view(5);
  const cv::Mat ref = normalise_thumbnail(*path_payload::make_thumbnail(a));
  // Turned left: content 15 px right at 320 px = 3 px at 64 px.
  cv::Mat darker;
  shifted(a, 15.0).convertTo(darker, -1, 0.6, 10.0);
  const cv::Mat live = normalise_thumbnail(*path_payload::make_thumbnail(darker));
  int best_shift = -99;
  double best = -2.0;
  for (int s = -10; s <= 10; ++s)
    if (const double c = thumbnail_ncc(live, ref, s); c > best) {
      best = c;
      best_shift = s;
    }
  EXPECT_EQ(best_shift, 3);
  EXPECT_GT(best, 0.85);
  // Another place correlates poorly at every shift.
  const cv::Mat other = normalise_thumbnail(*path_payload::make_thumbnail(view(77)));
  double other_best = -2.0;
  for (int s = -10; s <= 10; ++s) other_best = std::max(other_best, thumbnail_ncc(other, ref, s));
  EXPECT_LT(other_best, 0.6);
  // Less than half the width overlapping: no comparison.
  EXPECT_EQ(thumbnail_ncc(live, ref, 40), -1.0);
}

TEST(Thumbnail, TwoPassSearchFindsWhatTheExhaustiveOneFinds) {
  PlaceIndex index;
  index.edges.push_back({"p0", kPathKind, 60.0, 0});
  index.thumbnail_width_px = path_payload::kThumbnailWidthPx;
  index.thumbnail_height_px = path_payload::kThumbnailHeightPx;
  constexpr int kPlaces = 120;
  for (int k = 0; k < kPlaces; ++k) {
    index.thumbnail_places.push_back({0, 0.5f * static_cast<float>(k)});
    index.thumbnails.push_back(*path_payload::make_thumbnail(view(200 + k)));
  }
  index.prepare_thumbnails();
  ASSERT_EQ(index.coarse.size(), static_cast<std::size_t>(kPlaces));
  EXPECT_EQ(index.coarse[0].size(), cv::Size(index.thumbnail_width_px / 2, index.thumbnail_height_px / 2));
  std::vector<ThumbnailHit> exhaustive, two_pass;
  // Odd and even shifts (the coarse pass sees every other one), both signs, a darker view.
  const std::vector<std::pair<int, double>> cases = {{7, 15.0}, {33, -25.0}, {64, 0.0}, {90, 35.0}, {118, -5.0}};
  for (const auto& [place, dx_px] : cases) {
    cv::Mat live;
    shifted(view(200 + place), dx_px).convertTo(live, -1, 0.7, 12.0);
    const cv::Mat thumb = *path_payload::make_thumbnail(live);
    index.query_thumbnails(thumb, 32, 3, 0.4, exhaustive, 0);
    index.query_thumbnails(thumb, 32, 3, 0.4, two_pass, 16);
    ASSERT_FALSE(exhaustive.empty()) << place;
    ASSERT_FALSE(two_pass.empty()) << place;
    EXPECT_EQ(exhaustive[0].place, static_cast<std::uint32_t>(place));
    EXPECT_EQ(two_pass[0].place, exhaustive[0].place);
    EXPECT_EQ(two_pass[0].shift_px, exhaustive[0].shift_px);
    EXPECT_DOUBLE_EQ(two_pass[0].ncc, exhaustive[0].ncc);
    EXPECT_EQ(two_pass[0].shift_px, static_cast<int>(std::lround(dx_px / 5.0))) << place;
  }
  // As many coarse candidates as places: the exhaustive pass, the same hits.
  const cv::Mat thumb = *path_payload::make_thumbnail(view(250));
  index.query_thumbnails(thumb, 32, 3, 0.4, exhaustive, 0);
  index.query_thumbnails(thumb, 32, 3, 0.4, two_pass, kPlaces);
  ASSERT_EQ(two_pass.size(), exhaustive.size());
  for (std::size_t i = 0; i < exhaustive.size(); ++i) EXPECT_EQ(two_pass[i].place, exhaustive[i].place);
}

TEST(Thumbnail, FirstStageHandsTheViewedPlaceToTheTwoPassesAndItsCellsSurviveTheFile) {
  PlaceIndex index;
  index.edges.push_back({"p0", kPathKind, 300.0, 0});
  index.vocabulary = cv::Mat::zeros(index.params.vocabulary_words, 32, CV_8UC1);
  index.thumbnail_width_px = path_payload::kThumbnailWidthPx;
  index.thumbnail_height_px = path_payload::kThumbnailHeightPx;
  constexpr int kPlaces = 600;
  for (int k = 0; k < kPlaces; ++k) {
    index.thumbnail_places.push_back({0, 0.5f * static_cast<float>(k)});
    index.thumbnails.push_back(*path_payload::make_thumbnail(view(1000 + k)));
  }
  index.prepare_thumbnails();
  EXPECT_EQ(index.thumbnail_cells(), 55u) << "~sqrt(window vectors) cells";
  ASSERT_EQ(index.thumbnail_cell.size(), static_cast<std::size_t>(kPlaces * kStoredWindows));
  // Views of a place turned by up to 12 px of 64 (11 deg), darker: the first stage's 32 of 600
  // places hold it, and the search through the first stage answers what the exhaustive one does.
  std::vector<ThumbnailHit> exhaustive, staged;
  std::vector<std::uint32_t> first;
  const std::vector<std::pair<int, double>> cases = {{3, 20.0},   {77, -60.0}, {150, 0.0},  {231, 45.0},
                                                     {388, -30.0}, {452, 60.0}, {599, -10.0}};
  for (const auto& [place, dx_px] : cases) {
    cv::Mat live;
    shifted(view(1000 + place), dx_px).convertTo(live, -1, 0.7, 12.0);
    const cv::Mat thumb = *path_payload::make_thumbnail(live);
    index.thumbnail_first_stage(thumb, 32, first);
    ASSERT_EQ(first.size(), 32u);
    EXPECT_NE(std::find(first.begin(), first.end(), static_cast<std::uint32_t>(place)), first.end()) << place;
    index.query_thumbnails(thumb, 32, 3, 0.4, exhaustive, 0, 0);
    index.query_thumbnails(thumb, 32, 3, 0.4, staged, 16, 32);
    ASSERT_FALSE(exhaustive.empty()) << place;
    ASSERT_FALSE(staged.empty()) << place;
    EXPECT_EQ(exhaustive[0].place, static_cast<std::uint32_t>(place));
    EXPECT_EQ(staged[0].place, exhaustive[0].place);
    EXPECT_EQ(staged[0].shift_px, exhaustive[0].shift_px);
  }
  // The cells are stored (version 3) and read back as built.
  const std::vector<std::uint8_t> file = index.serialize();
  auto back = PlaceIndex::deserialize(file, "idx");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->thumbnail_cell, index.thumbnail_cell);
  EXPECT_EQ(back->thumbnail_centroids, index.thumbnail_centroids);
  // A version-2 file (no cells): still read, its cells trained at load (the same, deterministic).
  const std::size_t dims = static_cast<std::size_t>(signature_dims(index.thumbnail_height_px));
  const std::size_t cells_bytes =
      8 + 4 * (index.thumbnail_centroids.size() + static_cast<std::size_t>(kPlaces * kStoredWindows));
  EXPECT_EQ(index.thumbnail_centroids.size(), 55 * dims);
  std::vector<std::uint8_t> v2(file.begin(), file.end() - static_cast<std::ptrdiff_t>(cells_bytes));
  const std::span<const std::uint8_t> body(v2.data() + 24, v2.size() - 24);
  const std::uint32_t version = 2, crc = map_format::crc32(body);
  const std::uint64_t length = body.size();
  std::memcpy(v2.data() + 8, &version, 4);
  std::memcpy(v2.data() + 12, &crc, 4);
  std::memcpy(v2.data() + 16, &length, 8);
  auto old = PlaceIndex::deserialize(v2, "idx");
  ASSERT_TRUE(old.ok()) << old.error().message;
  EXPECT_EQ(old->thumbnail_cell, index.thumbnail_cell);
  // A cell id past the cells (a broken writer: the checksum matches) is a parse error.
  PlaceIndex broken = index;
  broken.thumbnail_cell[5] = 1000;
  auto bad = PlaceIndex::deserialize(broken.serialize(), "idx");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::parse_error);
  EXPECT_NE(bad.error().message.find("thumbnail cell"), std::string::npos) << bad.error().message;
}

class HybridMap : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("visnav_reloc_path_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    auto map = MapStore::create(dir_.string(), "hybrid");
    ASSERT_TRUE(map.ok()) << map.error().message;
    map_.emplace(std::move(*map));
    map_->set_sync(false);
    std::vector<std::string> nodes;
    for (const char* n : {"a", "b", "c", "d"}) {
      NodeRecord r;
      r.name = n;
      auto id = map_->add_node(r);
      ASSERT_TRUE(id.ok());
      nodes.push_back(*id);
    }
    auto add = [&](int from, const std::string& kind, double length_m, const std::vector<std::uint8_t>& body) {
      EdgeRecord e;
      e.from = nodes[static_cast<std::size_t>(from)];
      e.to = nodes[static_cast<std::size_t>(from + 1)];
      e.kind = kind;
      e.length_m = length_m;
      auto id = map_->add_edge(e, body);
      EXPECT_TRUE(id.ok()) << id.error().message;
      return *id;
    };
    // A local-maps edge (the index's vocabulary needs descriptors), a thumbnail path edge and an old one.
    std::mt19937 rng(3);
    feature_replay::LocalMapPath lm;
    std::uniform_int_distribution<int> byte(0, 255);
    for (int i = 0; i < 20; ++i) {
      feature_replay::LocalMap m;
      m.distance_m = 0.2 * i;
      m.descriptors.create(100, 32, CV_8UC1);
      for (int r = 0; r < 100; ++r) {
        for (int c = 0; c < 32; ++c) m.descriptors.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(byte(rng));
        m.positions_px.emplace_back(3.f * r, 100.f);
      }
      lm.maps.push_back(std::move(m));
    }
    lm.length_m = 3.8;
    lm.commands.push_back({0.0, Twist{0.3, 0.0}});
    feature_edge_ = add(0, kLocalMapsKind, 3.8, lm.serialize());
    path_edge_ = add(1, kPathKind, 0.5 * (kThumbs - 1), payload_of(200, kThumbs).encode());
    old_path_edge_ = add(2, kPathKind, 6.0, vpf1_body());
  }
  void TearDown() override {
    map_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  static PlaceIndexParams params() {
    PlaceIndexParams p;
    p.vocabulary_words = 128;
    p.vocabulary_sample = 2000;
    return p;
  }
  std::uint32_t edge_index(const PlaceIndex& index, const std::string& id) const {
    for (std::size_t i = 0; i < index.edges.size(); ++i)
      if (index.edges[i].id == id) return static_cast<std::uint32_t>(i);
    ADD_FAILURE() << "edge " << id << " not in the index";
    return 0;
  }

  static constexpr int kThumbs = 12;
  fs::path dir_;
  std::optional<MapStore> map_;
  std::string feature_edge_, path_edge_, old_path_edge_;
};

TEST_F(HybridMap, ThumbnailsArePlacesAndAnOldPathPayloadIsListedButNotCovered) {
  auto index = build_place_index(*map_, params());
  ASSERT_TRUE(index.ok()) << index.error().message;
  ASSERT_EQ(index->edges.size(), 3u);
  EXPECT_EQ(index->places.size(), 20u);
  ASSERT_EQ(index->thumbnail_places.size(), static_cast<std::size_t>(kThumbs));
  EXPECT_FLOAT_EQ(index->thumbnail_places[5].distance_m, 2.5f);
  EXPECT_TRUE(index->covers(edge_index(*index, feature_edge_)));
  EXPECT_TRUE(index->covers(edge_index(*index, path_edge_)));
  EXPECT_FALSE(index->covers(edge_index(*index, old_path_edge_)));
  EXPECT_TRUE(index->matches(*map_).ok());

  // Through the file: the thumbnails come back and are compared alike.
  auto back = PlaceIndex::deserialize(index->serialize(), "place_index.bin");
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->thumbnail_places.size(), static_cast<std::size_t>(kThumbs));
  EXPECT_EQ(cv::norm(back->thumbnails[7], index->thumbnails[7], cv::NORM_INF), 0.0);
  EXPECT_EQ(back->normalised.size(), static_cast<std::size_t>(kThumbs));
  // A damaged thumbnail byte is caught by the checksum.
  std::vector<std::uint8_t> bytes = index->serialize();
  bytes[bytes.size() - 10] ^= 0x40;
  EXPECT_EQ(PlaceIndex::deserialize(bytes, "place_index.bin").error().code, ErrorCode::parse_error);
}

TEST_F(HybridMap, AViewOfAThumbnailPlaceVotesForItWithTheHeadingOffset) {
  auto index = build_place_index(*map_, params());
  ASSERT_TRUE(index.ok()) << index.error().message;
  feature_replay::HeadingParams heading;  // 60 deg
  PlaceVerifier verifier(*index, *map_, heading);
  RelocaliseParams rp;
  const std::uint32_t path = edge_index(*index, path_edge_);
  int right = 0;
  for (int k = 0; k < kThumbs; ++k) {
    // The robot turned ~4.7 deg left (content 25 px right at 320 px and 60 deg).
    auto votes = verifier.thumbnail_votes(shifted(view(200 + k), 25.0), rp);
    ASSERT_TRUE(votes.ok()) << votes.error().message;
    ASSERT_FALSE(votes->empty()) << k;
    const PlaceVote& v = votes->front();
    if (v.edge == path && std::abs(v.distance_m - 0.5 * k) < 1e-6) ++right;
    EXPECT_GE(v.confidence, std::min(1.0, rp.min_thumbnail_ncc / rp.thumbnail_confident_ncc));
    EXPECT_NEAR(v.heading_offset_rad * 180.0 / M_PI, 4.7, 1.0);
    EXPECT_NEAR(v.score, v.confidence * rp.thumbnail_vote_weight, 1e-9);
  }
  EXPECT_EQ(right, kThumbs);
  // A view of nowhere on the map: no thumbnail vote.
  auto none = verifier.thumbnail_votes(view(9999), rp);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST_F(HybridMap, APathOnlyMapHasNothingToBuildAVocabularyFrom) {
  // The map without its feature edge: not_found, naming why (BuildPlaceIndex logs it and succeeds).
  fs::path other = dir_.string() + "_pathonly";
  fs::remove_all(other);
  auto map = MapStore::create(other.string(), "path only");
  ASSERT_TRUE(map.ok());
  map->set_sync(false);
  NodeRecord a, b;
  a.name = "a";
  b.name = "b";
  auto ia = map->add_node(a);
  auto ib = map->add_node(b);
  EdgeRecord e;
  e.from = *ia;
  e.to = *ib;
  e.kind = kPathKind;
  e.length_m = 2.0;
  ASSERT_TRUE(map->add_edge(e, payload_of(1, 4).encode()).ok());
  auto index = build_place_index(*map, params());
  ASSERT_FALSE(index.ok());
  EXPECT_EQ(index.error().code, ErrorCode::not_found);
  fs::remove_all(other);
}
