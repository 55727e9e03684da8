// Matching + histogram voting: known shifts on synthetic features, real-photo crops (with
// brightness/contrast change), the rectified stereo pair, and bad inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/feature_replay/heading.hpp"

namespace fr = visnav::feature_replay;
using visnav::Features;

namespace {

// Random features; the "current" set is the reference shifted by (shift, 0) with some outliers.
// The same set under every compiler and in every test order: the descriptors come from an own
// cv::RNG (cv::randu draws from OpenCV's per-thread theRNG(), whose state depends on what ran
// before in the process), and u and v are drawn in sequenced statements (in
// `KeyPoint(ux(rng), uy(rng), ...)` the argument order is unspecified: gcc draws v first, clang
// u, which gave the two builds different layouts).
void make_shifted(int n, double shift_px, int outliers, Features& ref, Features& cur, unsigned seed = 3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  ref.clear();
  cur.clear();
  ref.descriptors.create(n, 32, CV_8UC1);
  cv::RNG descriptor_rng(seed);
  descriptor_rng.fill(ref.descriptors, cv::RNG::UNIFORM, 0, 256);
  for (int i = 0; i < n; ++i) {
    const float u = ux(rng);
    const float v = uy(rng);
    ref.keypoints.emplace_back(u, v, 7.0f);
  }
  cur.descriptors = ref.descriptors.clone();
  for (int i = 0; i < n; ++i) {
    cv::KeyPoint k = ref.keypoints[static_cast<std::size_t>(i)];
    k.pt.x += static_cast<float>(shift_px);
    if (i < outliers) {  // a wrong position for the same descriptor
      k.pt.x = ux(rng);
    }
    cur.keypoints.push_back(k);
  }
}

}  // namespace

TEST(HeadingParams, SchemaParsesAndValidates) {
  visnav::ConfigNode node = visnav::ConfigNode::make_map();
  node.set("bin_width_px", visnav::ConfigNode::make_scalar("10"));
  node.set("bin_count", visnav::ConfigNode::make_scalar("61"));
  auto p = fr::HeadingParams::schema().parse(node);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->bin_count, 61);
  node.set("bin_count", visnav::ConfigNode::make_scalar("40"));
  EXPECT_FALSE(fr::HeadingParams::schema().parse(node).ok());  // even
  node.set("bin_count", visnav::ConfigNode::make_scalar("41"));
  node.set("no_such_key", visnav::ConfigNode::make_scalar("1"));
  EXPECT_FALSE(fr::HeadingParams::schema().parse(node).ok());
  // Defaults are the stroll_bearnav histogram: 41 bins of 20 px.
  EXPECT_EQ(fr::HeadingParams{}.bin_count, 41);
  EXPECT_DOUBLE_EQ(fr::HeadingParams{}.bin_width_px, 20.0);
}

TEST(HeadingEstimator, RecoversSyntheticShiftsWithOutliers) {
  fr::HeadingEstimator est;
  Features ref, cur;
  for (double shift : {-123.4, -37.0, -9.5, 0.0, 4.25, 19.9, 60.0, 250.0}) {
    make_shifted(300, shift, 90, ref, cur);
    auto e = est.estimate(ref, cur, 640.0);
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_NEAR(e->offset_px, shift, 0.5) << "shift " << shift;
    EXPECT_GE(e->inliers, 200);
    EXPECT_TRUE(e->valid);
    EXPECT_GT(e->confidence, 0.8);
    // positive offset (content moved right = camera turned left) -> negative (clockwise) correction
    if (shift > 1.0) {
      EXPECT_LT(e->heading_correction_rad, 0.0);
    }
    if (shift < -1.0) {
      EXPECT_GT(e->heading_correction_rad, 0.0);
    }
    const double focal = 320.0 / std::tan(30.0 * M_PI / 180.0);
    EXPECT_NEAR(e->heading_correction_rad, -std::atan(shift / focal), 1e-3);
  }
}

TEST(HeadingEstimator, VerticalGateAndCrossCheck) {
  Features ref, cur;
  make_shifted(100, 30.0, 0, ref, cur);
  for (auto& k : cur.keypoints) k.pt.y += 80.0f;  // every true pair is beyond the 50 px gate
  fr::HeadingEstimator est;
  auto e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_FALSE(e->valid);
  // The gate is applied while searching, so a query only sees the reference features within
  // 50 px of its v. No true pair (identical descriptor, dv = 80) is among them. A query whose
  // window holds exactly one (unrelated) feature passes the ratio test by definition ("a single
  // candidate passes"); with two or more random 256-bit candidates the ratio test rejects.
  std::vector<int> candidates(cur.keypoints.size(), 0);
  for (std::size_t i = 0; i < cur.keypoints.size(); ++i)
    for (const auto& r : ref.keypoints)
      if (std::abs(cur.keypoints[i].pt.y - r.pt.y) <= 50.0f) ++candidates[i];
  const auto lone = std::count(candidates.begin(), candidates.end(), 1);
  EXPECT_EQ(e->matches, lone);
  for (const auto& m : est.last_matches()) {
    EXPECT_NE(m.current_index, m.reference_index) << "a true pair passed the gate";
    EXPECT_LE(std::abs(m.dv_px), 50.0f);
    EXPECT_EQ(candidates[static_cast<std::size_t>(m.current_index)], 1);
    EXPECT_GT(m.distance, 64.0f);  // a chance pair of random descriptors
  }
  // An absolute descriptor gate removes those chance pairs: nothing beyond the gate matches.
  fr::HeadingParams p;
  p.max_descriptor_distance = 64.0;
  est.set_params(p);
  e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->matches, 0);
  EXPECT_FALSE(e->valid);
  p = fr::HeadingParams{};
  p.max_vertical_px = 0.0;  // off
  p.cross_check = true;
  est.set_params(p);
  e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->matches, 100);
  EXPECT_NEAR(e->offset_px, 30.0, 0.01);
}

TEST(HeadingEstimator, BadInputsDoNotCrash) {
  fr::HeadingEstimator est;
  Features ref, cur, empty;
  make_shifted(50, 10.0, 0, ref, cur);
  // empty current / empty reference: ok, not valid
  auto e = est.estimate(ref, empty, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_FALSE(e->valid);
  EXPECT_EQ(e->matches, 0);
  e = est.estimate(empty, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_FALSE(e->valid);
  // keypoints and descriptor rows disagree
  Features broken = cur;
  broken.keypoints.pop_back();
  EXPECT_FALSE(est.estimate(ref, broken, 640.0).ok());
  // descriptor width mismatch (another detector)
  Features wide = cur;
  wide.descriptors = cv::Mat(cur.descriptors.rows, 64, CV_8UC1, cv::Scalar(1));
  auto w = est.estimate(ref, wide, 640.0);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().message.find("descriptor mismatch"), std::string::npos);
  // float vs binary
  Features flt = cur;
  flt.descriptors = cv::Mat(cur.descriptors.rows, 32, CV_32FC1, cv::Scalar(0.5));
  EXPECT_FALSE(est.estimate(ref, flt, 640.0).ok());
  // unsupported descriptor type
  Features bad = cur;
  bad.descriptors = cv::Mat(cur.descriptors.rows, 32, CV_16UC1, cv::Scalar(1));
  EXPECT_FALSE(est.estimate(bad, cur, 640.0).ok());
  // NaN positions are ignored, not voted
  Features nan = cur;
  for (auto& k : nan.keypoints) k.pt.x = std::nanf("");
  e = est.estimate(ref, nan, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->matches, 0);
}

TEST(HeadingEstimator, FloatDescriptorsUseL2) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  Features ref, cur;
  ref.norm = cur.norm = visnav::DescriptorNorm::l2;
  ref.descriptors.create(200, 64, CV_32FC1);
  cv::randu(ref.descriptors, 0.0f, 1.0f);
  cur.descriptors = ref.descriptors + 0.01f;
  for (int i = 0; i < 200; ++i) {
    ref.keypoints.emplace_back(ux(rng), uy(rng), 7.0f);
    cur.keypoints.push_back(ref.keypoints.back());
    cur.keypoints.back().pt.x -= 42.0f;
  }
  fr::HeadingEstimator est;
  auto e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_NEAR(e->offset_px, -42.0, 0.01);
}

TEST(HeadingEstimator, RandomMatchesGiveLowConfidence) {
  // Unrelated features: the histogram is flat, the estimate must not be valid.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  Features ref, cur;
  ref.descriptors.create(400, 32, CV_8UC1);
  cur.descriptors.create(400, 32, CV_8UC1);
  cv::randu(ref.descriptors, 0, 256);
  cv::randu(cur.descriptors, 0, 256);
  for (int i = 0; i < 400; ++i) {
    ref.keypoints.emplace_back(ux(rng), uy(rng), 7.0f);
    cur.keypoints.emplace_back(ux(rng), uy(rng), 7.0f);
  }
  fr::HeadingParams p;
  p.ratio = 1.0;  // let every random pair through: worst case for the vote
  p.max_vertical_px = 0.0;
  fr::HeadingEstimator est(p);
  auto e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_GT(e->matches, 100);
  EXPECT_FALSE(e->valid) << "confidence " << e->confidence << " inliers " << e->inliers;
}

TEST(HeadingEstimator, AllFeaturesOnOneSide) {
  // Every feature in the left 80 px of the image: still estimated, no crash.
  Features ref, cur;
  make_shifted(120, -15.0, 0, ref, cur);
  for (std::size_t i = 0; i < ref.keypoints.size(); ++i) {
    ref.keypoints[i].pt.x = std::fmod(ref.keypoints[i].pt.x, 80.0f) + 20.0f;
    cur.keypoints[i].pt.x = ref.keypoints[i].pt.x - 15.0f;
  }
  fr::HeadingEstimator est;
  auto e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_NEAR(e->offset_px, -15.0, 0.5);
}

TEST(HeadingEstimator, DoesNotAllocateAfterWarmUp) {
  // Same-size inputs twice: the match buffer keeps its storage.
  Features ref, cur;
  make_shifted(300, 12.0, 30, ref, cur);
  fr::HeadingEstimator est;
  ASSERT_TRUE(est.estimate(ref, cur, 640.0).ok());
  const auto* before = est.last_matches().data();
  ASSERT_TRUE(est.estimate(ref, cur, 640.0).ok());
  EXPECT_EQ(before, est.last_matches().data());
}

// ---- real photographs ----

namespace {
struct Crop {
  const char* image;
  int x0, y0, w, h;
};

double align_crops(const cv::Mat& img, const Crop& c, int shift_px, bool photometric, int* inliers = nullptr) {
  // A at x0, B at x0 + shift: the scene in B is at (position in A) - shift.
  const cv::Mat a = img(cv::Rect(c.x0, c.y0, c.w, c.h)).clone();
  cv::Mat b = img(cv::Rect(c.x0 + shift_px, c.y0, c.w, c.h)).clone();
  if (photometric) b.convertTo(b, -1, 1.35, -25.0);  // contrast x1.35, brightness -25
  const Features fa = fr_test::orb_features(a), fb = fr_test::orb_features(b);
  fr::HeadingEstimator est;
  auto e = est.estimate(fa, fb, static_cast<double>(c.w));
  EXPECT_TRUE(e.ok());
  if (!e.ok()) return 1e9;
  if (inliers != nullptr) *inliers = e->inliers;
  EXPECT_TRUE(e->valid) << c.image << " shift " << shift_px << " confidence " << e->confidence;
  return e->offset_px;
}
}  // namespace

TEST(HeadingEstimatorRealPhotos, KnownShiftsWithinThreePixels) {
  const Crop crops[] = {{"camera.png", 60, 80, 360, 300},
                        {"astronaut.png", 60, 60, 360, 320},
                        {"coffee.png", 80, 40, 400, 300},
                        {"chelsea.png", 60, 20, 320, 260},
                        {"motorcycle_left.png", 120, 80, 480, 360}};
  int tested = 0;
  for (const auto& c : crops) {
    const cv::Mat img = fr_test::load_grey(c.image);
    if (img.empty()) continue;
    ++tested;
    for (int shift : {-57, -23, -8, 0, 5, 17, 44}) {
      for (bool photometric : {false, true}) {
        const double off = align_crops(img, c, shift, photometric);
        EXPECT_NEAR(off, -shift, 3.0) << c.image << " shift " << shift << (photometric ? " (photometric)" : "");
      }
    }
  }
  if (tested == 0) GTEST_SKIP() << "python3-skimage photos not installed";
}

TEST(HeadingEstimatorRealPhotos, RectifiedStereoPair) {
  // Middlebury "motorcycle" pair: x_right = x_left - disparity, disparity 7..60 px (median ~39).
  const cv::Mat l = fr_test::load_grey("motorcycle_left.png"), r = fr_test::load_grey("motorcycle_right.png");
  if (l.empty() || r.empty()) GTEST_SKIP() << "stereo pair not installed";
  const Features fl = fr_test::orb_features(l, 1000), fr_ = fr_test::orb_features(r, 1000);
  fr::HeadingParams p;
  p.max_vertical_px = 3.0;  // rectified: rows agree
  fr::HeadingEstimator est(p);
  auto e = est.estimate(fl, fr_, static_cast<double>(l.cols));
  ASSERT_TRUE(e.ok());
  EXPECT_TRUE(e->valid);
  EXPECT_LT(e->offset_px, -7.0);
  EXPECT_GT(e->offset_px, -60.0);
  EXPECT_GT(e->inliers, 50);
  for (const auto& m : est.last_matches()) EXPECT_LE(std::abs(m.dv_px), 3.0f);
}

TEST(HeadingEstimator, NonFiniteReferencePositionsAreSkipped) {
  Features ref, cur;
  make_shifted(200, 8.0, 0, ref, cur);
  for (std::size_t i = 0; i < ref.keypoints.size(); i += 3) ref.keypoints[i].pt.y = std::nanf("");
  fr::HeadingEstimator est;
  auto e = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(e.ok());
  EXPECT_NEAR(e->offset_px, 8.0, 0.5);
  for (const auto& m : est.last_matches()) EXPECT_NE(m.reference_index % 3, 0);
}

// Ambiguity = second histogram peak / first: one offset gives ~0, two equally supported
// offsets (half the features moved by another amount) give ~1 and an invalid estimate.
TEST(HeadingEstimator, AmbiguityIsTheSecondPeakOverTheFirst) {
  fr::HeadingParams p;
  p.ratio = 1.0;  // identical descriptors: the ratio test would see ties only with duplicates
  fr::HeadingEstimator est(p);
  Features ref, cur;
  make_shifted(300, 40.0, 0, ref, cur);
  auto one = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(one.ok());
  EXPECT_LT(one->ambiguity, 0.05);
  EXPECT_TRUE(one->valid);
  // Half of the current features moved by -120 px instead of +40 px.
  for (std::size_t i = 0; i < cur.keypoints.size(); i += 2) cur.keypoints[i].pt.x -= 160.0f;
  auto two = est.estimate(ref, cur, 640.0);
  ASSERT_TRUE(two.ok());
  EXPECT_GT(two->ambiguity, 0.8);
  EXPECT_NEAR(two->confidence, std::min(1.0, two->inliers / 30.0) * (1.0 - two->ambiguity), 1e-9);
  EXPECT_FALSE(two->valid);
  // No votes at all: fully ambiguous.
  Features none;
  auto empty = est.estimate(ref, none, 640.0);
  ASSERT_TRUE(empty.ok());
  EXPECT_DOUBLE_EQ(empty->ambiguity, 1.0);
}
