// Place index over visual_memory edges (issue 21): their payload stores reference images and no
// descriptors, so the index describes the images with a detector at build time; a frame of one
// reference (turned) finds that reference with the heading offset of the turn.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/map.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/relocalisation/verifier.hpp"
#include "visnav/visual_memory_payload.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::reloc;

namespace {

/// ORB on the image, 32-byte descriptors (the test's stand-in for a detector plugin).
class OrbDetector final : public Detector {
 public:
  explicit OrbDetector(int features = 300, int wta_k = 2)
      : orb_(cv::ORB::create(features, 1.2f, 8, 31, 0, wta_k)) {}
  Status detect(const cv::Mat& image, Features& out) override {
    out.keypoints.clear();
    orb_->detectAndCompute(image, cv::noArray(), out.keypoints, out.descriptors);
    return ok();
  }
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 private:
  cv::Ptr<cv::ORB> orb_;
};

/// A textured 320x240 grey image of its own (blurred noise: many corners, none shared).
cv::Mat texture(int seed) {
  cv::Mat noise(60, 80, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat image;
  cv::resize(noise, image, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

/// `image` with its content moved `dx_px` to the right (the camera turned left).
cv::Mat shifted(const cv::Mat& image, double dx_px) {
  cv::Mat out;
  const cv::Matx23d m(1, 0, dx_px, 0, 1, 0);
  cv::warpAffine(image, out, m, image.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

class MemoryMap : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("visnav_reloc_vm_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    auto map = MapStore::create(dir_.string(), "visual memory");
    ASSERT_TRUE(map.ok()) << map.error().message;
    map_.emplace(std::move(*map));
    map_->set_sync(false);
    NodeRecord a, b;
    a.name = "a";
    b.name = "b";
    auto ia = map_->add_node(a);
    auto ib = map_->add_node(b);
    ASSERT_TRUE(ia.ok() && ib.ok());
    visual_memory::VisualMemory m;
    m.width_px = 320;
    m.height_px = 240;
    m.focal_px = 160.0 / std::tan(30.0 * M_PI / 180.0);
    for (int k = 0; k < kReferences; ++k) {
      visual_memory::Reference r;
      r.distance_m = 0.5 * k;
      r.image = texture(100 + k);
      m.references.push_back(std::move(r));
    }
    EdgeRecord e;
    e.from = *ia;
    e.to = *ib;
    e.kind = kMemoryKind;
    e.length_m = 0.5 * (kReferences - 1);
    auto id = map_->add_edge(e, m.encode());
    ASSERT_TRUE(id.ok()) << id.error().message;
    edge_id_ = *id;
  }
  void TearDown() override {
    map_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  static PlaceIndexParams params() {
    PlaceIndexParams p;
    p.vocabulary_words = 256;
    p.vocabulary_sample = 3000;
    return p;
  }

  static constexpr int kReferences = 10;
  fs::path dir_;
  std::optional<MapStore> map_;
  std::string edge_id_;
};

}  // namespace

TEST_F(MemoryMap, EveryReferenceIsAPlaceFoundFromATurnedView) {
  OrbDetector detector;
  auto index = build_place_index(*map_, params(), &detector);
  ASSERT_TRUE(index.ok()) << index.error().message;
  ASSERT_EQ(index->edges.size(), 1u);
  EXPECT_EQ(index->edges[0].kind, kMemoryKind);
  ASSERT_EQ(index->places.size(), static_cast<std::size_t>(kReferences));
  for (int k = 0; k < kReferences; ++k) EXPECT_FLOAT_EQ(index->places[static_cast<std::size_t>(k)].distance_m, 0.5f * k);

  feature_replay::HeadingParams heading;  // 60 deg field of view
  PlaceVerifier verifier(*index, *map_, heading, &detector);
  const double focal_px = 160.0 / std::tan(30.0 * M_PI / 180.0);
  int found = 0;
  for (int k = 0; k < kReferences; ++k) {
    Features current;
    ASSERT_TRUE(detector.detect(shifted(texture(100 + k), 30.0), current).ok());
    auto votes = verifier.votes(current, 320.0, 4, 0.3);
    ASSERT_TRUE(votes.ok()) << votes.error().message;
    if (votes->empty()) continue;
    const PlaceVote& v = votes->front();
    if (std::abs(v.distance_m - 0.5 * k) < 1e-4) ++found;
    // Content 30 px right: the robot is turned left of the taught heading (positive offset).
    EXPECT_NEAR(v.heading_offset_rad, std::atan(30.0 / focal_px), 0.03) << "reference " << k;
  }
  EXPECT_GE(found, kReferences - 1);

  // An image of no reference: nothing verifies.
  Features other;
  ASSERT_TRUE(detector.detect(texture(7), other).ok());
  auto none = verifier.votes(other, 320.0, 4, 0.3);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST_F(MemoryMap, WithoutADetectorTheEdgeIsRefusedNamingTheFix) {
  auto index = build_place_index(*map_, params());
  ASSERT_FALSE(index.ok());
  EXPECT_EQ(index.error().code, ErrorCode::invalid_value);
  EXPECT_NE(index.error().message.find(edge_id_), std::string::npos);
}

TEST_F(MemoryMap, AnIndexBuiltBeforeVisualMemoryWasIndexedIsStale) {
  OrbDetector detector;
  auto index = build_place_index(*map_, params(), &detector);
  ASSERT_TRUE(index.ok()) << index.error().message;
  EXPECT_TRUE(index->matches(*map_).ok());
  PlaceIndex old = *index;  // as an index of session 7 would be: the memory edge not covered
  old.edges.clear();
  const Status stale = old.matches(*map_);
  ASSERT_FALSE(stale.ok());
  EXPECT_EQ(stale.error().code, ErrorCode::inconsistent);
}

TEST_F(MemoryMap, TheIndexRecordsItsDetectorAndRefusesAnotherOne) {
  OrbDetector detector;
  auto index = build_place_index(*map_, params(), &detector, {}, "orb");
  ASSERT_TRUE(index.ok()) << index.error().message;
  EXPECT_EQ(index->detector, "orb");
  auto back = PlaceIndex::deserialize(index->serialize(), "place_index.bin");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->detector, "orb");
  // The same detector (another instance, same params) passes.
  OrbDetector same;
  EXPECT_TRUE(check_detector(*map_, *back, &same).ok());
  // Another detector of the same width (ORB's 3-point BRIEF tests: other bits, same 32 bytes)
  // is refused, naming the recorded one and the fix.
  OrbDetector other(300, 3);
  auto st = check_detector(*map_, *back, &other);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::inconsistent);
  EXPECT_NE(st.error().message.find("orb"), std::string::npos) << st.error().message;
  EXPECT_NE(st.error().message.find("reloc-index"), std::string::npos) << st.error().message;
  // No detector at all: an error, not a crash.
  EXPECT_FALSE(check_detector(*map_, *back, nullptr).ok());
}
