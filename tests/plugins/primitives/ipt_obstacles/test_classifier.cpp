// The obstacle/ground classifier (spec §11 items 4, 5, 8): analytic D, the thesis thresholds,
// false positives growing with range.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/classifier.hpp"

namespace visnav::ipt {
namespace {

using testing::thesis_rig;

struct Track {
  cv::Point2f a, b;
};

Track track_of(const IptCamera& cam, const LensPose& l0, const LensPose& l1, const cv::Vec3d& p) {
  const auto a = project_point(cam, l0, p);
  const auto b = project_point(cam, l1, p);
  EXPECT_TRUE(a && b);
  return {cv::Point2f(static_cast<float>(a->x), static_cast<float>(a->y)),
          cv::Point2f(static_cast<float>(b->x), static_cast<float>(b->y))};
}

TEST(IptClassifier, DiscrepancyUnderPureTranslationIsTheAnalyticValue) {
  const IptCamera cam = thesis_rig();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> x(-0.6, 0.6), y(0.9, 2.5), h(0.0, 0.40), dir(-0.5, 0.5);
  for (int i = 0; i < 300; ++i) {
    const double t = 0.02, heading = CV_PI / 2 + dir(rng);  // translate 2 cm along a heading near the view
    const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{t * std::cos(heading), t * std::sin(heading), CV_PI / 2};
    const cv::Vec3d p(x(rng), y(rng), h(rng));
    const auto a = project_point(cam, l0, p), b = project_point(cam, l1, p);
    ASSERT_TRUE(a && b);
    const double d = discrepancy_m(cam, l0, l1, *a, *b);
    EXPECT_NEAR(d, t * p[2] / (cam.height_m - p[2]), 1e-7) << "h " << p[2];
  }
  // a reflection (a virtual point below the floor) gives D < |t|
  const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{0.0, 0.02, CV_PI / 2};
  const cv::Vec3d mirror(0.1, 1.5, -0.6);
  const double d_mirror = discrepancy_m(cam, l0, l1, *project_point(cam, l0, mirror), *project_point(cam, l1, mirror));
  EXPECT_NEAR(d_mirror, 0.02 * 0.6 / (0.43 + 0.6), 1e-7);
  EXPECT_LT(d_mirror, 0.02);
}

TEST(IptClassifier, PureRotationAboutTheLensGivesNoDiscrepancy) {
  const IptCamera cam = thesis_rig();
  const LensPose l0{0.3, 0.4, 1.2}, l1{0.3, 0.4, 1.35};
  const cv::Vec3d p(0.3 + 1.5 * std::cos(1.28), 0.4 + 1.5 * std::sin(1.28), 0.3);  // 30 cm up, seen from both
  const double d = discrepancy_m(cam, l0, l1, *project_point(cam, l0, p), *project_point(cam, l1, p));
  EXPECT_NEAR(d, 0.0, 1e-9);
}

TEST(IptClassifier, ThesisThresholdsOnDiscrepancies) {
  const ClassifierParams params;
  ASSERT_TRUE(params.validate().ok());
  ClassReason r{};
  EXPECT_EQ(label_for_discrepancy(0.010, params, &r), FeatureClass::ground);
  EXPECT_EQ(r, ClassReason::d_ground);
  EXPECT_EQ(label_for_discrepancy(0.030, params, &r), FeatureClass::unclassified);
  EXPECT_EQ(r, ClassReason::d_band);
  EXPECT_EQ(label_for_discrepancy(0.060, params, &r), FeatureClass::obstacle);
  EXPECT_EQ(r, ClassReason::d_obstacle);
  ClassifierParams no_band;
  no_band.unclassified_bands_m.clear();
  EXPECT_EQ(label_for_discrepancy(0.030, no_band), FeatureClass::obstacle);
}

TEST(IptClassifier, HeightsLabelledAsTheSpecDerivesForTwoCentimetres) {
  // spec §3.5: Z0 = 430 mm, |t| = 20 mm: below ~220 mm ground, 220-307 mm unclassified, above obstacle.
  const IptCamera cam = thesis_rig();
  const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{0.0, 0.02, CV_PI / 2};
  std::vector<cv::Point2f> a, b;
  for (const double h : {0.15, 0.26, 0.35, 0.0, 1.2}) {
    const Track t = track_of(cam, l0, l1, {0.2, 1.4, h});
    a.push_back(t.a);
    b.push_back(t.b);
  }
  auto out = classify_features(cam, l0, l1, a, b, ClassifierParams{});
  ASSERT_TRUE(out.ok());
  ASSERT_EQ(out->size(), 5u);
  EXPECT_EQ((*out)[0].label, FeatureClass::ground);
  EXPECT_EQ((*out)[1].label, FeatureClass::unclassified);
  EXPECT_EQ((*out)[2].label, FeatureClass::obstacle);
  EXPECT_EQ((*out)[2].reason, ClassReason::d_obstacle);
  EXPECT_EQ((*out)[3].label, FeatureClass::ground);
  EXPECT_NEAR((*out)[3].ground_m.x, 0.2, 1e-4);  // float pixels
  EXPECT_NEAR((*out)[3].ground_m.y, 1.4, 1e-3);
  EXPECT_EQ((*out)[4].label, FeatureClass::obstacle);
  EXPECT_EQ((*out)[4].reason, ClassReason::above_horizon);
  EXPECT_LT((*out)[4].discrepancy_m, 0.0);
  // The 35 cm point projects 7.5 m out: the literal spec range cut would drop it.
  ClassifierParams literal;
  literal.max_range_applies_to_obstacles = true;
  auto cut = classify_features(cam, l0, l1, a, b, literal);
  ASSERT_TRUE(cut.ok());
  EXPECT_EQ((*cut)[2].label, FeatureClass::unclassified);
  EXPECT_EQ((*cut)[2].reason, ClassReason::beyond_range);
  EXPECT_EQ((*cut)[0].label, FeatureClass::ground);  // a near ground point is unaffected
}

TEST(IptClassifier, StandingStillClassifiesNothingBelowTheHorizon) {
  const IptCamera cam = thesis_rig();
  const LensPose l{0.0, 0.0, CV_PI / 2};
  const Track g = track_of(cam, l, l, {0.0, 1.2, 0.0});
  const Track o = track_of(cam, l, l, {0.0, 1.2, 2.0});
  const std::vector<cv::Point2f> a{g.a, o.a}, b{g.b, o.b};
  auto out = classify_features(cam, l, l, a, b, ClassifierParams{});
  ASSERT_TRUE(out.ok());
  EXPECT_EQ((*out)[0].label, FeatureClass::unclassified);
  EXPECT_EQ((*out)[0].reason, ClassReason::no_baseline);
  EXPECT_EQ((*out)[1].label, FeatureClass::obstacle);  // the horizon test needs no parallax
  const std::vector<cv::Point2f> one{g.a};
  auto bad = classify_features(cam, l, l, one, b, ClassifierParams{});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::invalid_value);
}

TEST(IptClassifier, AProjectionMovingWithTheLensIsNotAnObstacle) {
  // A ground corner whose track slid 8 cm forward along the travel (+y): |D| = 8 cm says OBSTACLE,
  // but a point above the ground moves back (−t·h/(Z0 − h)); moving forward it would lie below
  // the floor. The direction test leaves it unclassified; a slide backwards looks like height and
  // stays OBSTACLE; a real 35 cm point stays OBSTACLE.
  const IptCamera cam = thesis_rig();
  const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{0.0, 0.02, CV_PI / 2};
  const cv::Vec3d ground(0.2, 2.0, 0.0);
  auto slid = [&](double dy) {
    const auto a = project_point(cam, l0, ground);
    const auto b = project_point(cam, l1, ground + cv::Vec3d(0.0, dy, 0.0));
    EXPECT_TRUE(a && b);
    return Track{cv::Point2f(static_cast<float>(a->x), static_cast<float>(a->y)),
                 cv::Point2f(static_cast<float>(b->x), static_cast<float>(b->y))};
  };
  const Track forward = slid(0.08), backward = slid(-0.08), tall = track_of(cam, l0, l1, {0.2, 1.4, 0.35});
  const std::vector<cv::Point2f> a{forward.a, backward.a, tall.a}, b{forward.b, backward.b, tall.b};
  ClassifierParams direction;
  direction.signed_discrepancy = true;
  auto out = classify_features(cam, l0, l1, a, b, direction);
  ASSERT_TRUE(out.ok());
  EXPECT_NEAR((*out)[0].discrepancy_m, 0.08, 2e-3);
  EXPECT_EQ((*out)[0].label, FeatureClass::unclassified);
  EXPECT_EQ((*out)[0].reason, ClassReason::d_below_ground);
  EXPECT_EQ((*out)[1].label, FeatureClass::obstacle);
  EXPECT_EQ((*out)[2].label, FeatureClass::obstacle);
  auto plain = classify_features(cam, l0, l1, a, b, ClassifierParams{});  // the thesis: off by default
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ((*plain)[0].label, FeatureClass::obstacle);
  EXPECT_EQ((*plain)[0].reason, ClassReason::d_obstacle);
}

TEST(IptClassifier, TheDirectionTestHalvesNoiseObstaclesAtACostInHighPoints) {
  // 0.2 px of tracking noise (the forward-backward limit) on ground corners 2.5-3.5 m ahead (the
  // false obstacle features of the campus hall's tiles, session 14): about half of those that D
  // labels OBSTACLE moved with the lens and lose the label (measured 69 -> 35). The cost: points
  // 0.3-0.4 m high (below the 0.43 m lens) 1-2 m ahead project 3-14 m out, where the same noise
  // moves the projection by more than the height's displacement, and lose about a third of their
  // OBSTACLE labels (measured 500 -> 341; on the rendered obstacle course 432 -> 399 below the
  // horizon, docs/obstacles.md).
  const IptCamera cam = thesis_rig();
  const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{0.0, 0.02, CV_PI / 2};
  std::mt19937 rng(23);
  std::normal_distribution<float> noise(0.0f, 0.2f);
  std::uniform_real_distribution<double> lateral(-0.5, 0.5), unit(0.0, 1.0);
  std::vector<cv::Point2f> ga, gb, oa, ob;
  for (int i = 0; i < 600; ++i) {
    const double x = lateral(rng);
    const double y = 2.5 + unit(rng);
    Track g = track_of(cam, l0, l1, {x, y, 0.0});
    const float n1 = noise(rng);
    const float n2 = noise(rng);
    const float n3 = noise(rng);
    const float n4 = noise(rng);
    g.a += cv::Point2f(n1, n2);
    g.b += cv::Point2f(n3, n4);
    ga.push_back(g.a);
    gb.push_back(g.b);
    const double ox = lateral(rng);
    const double oy = 1.0 + unit(rng);
    const double oh = 0.3 + 0.1 * unit(rng);
    Track o = track_of(cam, l0, l1, {ox, oy, oh});
    const float m1 = noise(rng);
    const float m2 = noise(rng);
    const float m3 = noise(rng);
    const float m4 = noise(rng);
    o.a += cv::Point2f(m1, m2);
    o.b += cv::Point2f(m3, m4);
    oa.push_back(o.a);
    ob.push_back(o.b);
  }
  const ClassifierParams thesis;  // off by default
  ClassifierParams direction;
  direction.signed_discrepancy = true;
  auto count = [](const Result<std::vector<ClassifiedFeature>>& r) {
    EXPECT_TRUE(r.ok());
    long n = 0;
    for (const auto& f : *r) n += f.label == FeatureClass::obstacle ? 1 : 0;
    return n;
  };
  const long noise_plain = count(classify_features(cam, l0, l1, ga, gb, thesis));
  const long noise_signed = count(classify_features(cam, l0, l1, ga, gb, direction));
  const long real_plain = count(classify_features(cam, l0, l1, oa, ob, thesis));
  const long real_signed = count(classify_features(cam, l0, l1, oa, ob, direction));
  EXPECT_GT(noise_plain, 30);  // the case exists
  EXPECT_LT(noise_signed, 0.6 * static_cast<double>(noise_plain));
  EXPECT_GT(real_plain, 400);
  EXPECT_GE(real_signed, 0.6 * static_cast<double>(real_plain));
  EXPECT_LT(real_signed, real_plain);  // the cost exists
}

TEST(IptClassifier, FalseObstaclesOnTheGroundGrowWithRange) {
  // spec §11.8: half a pixel of tracking noise pushes distant ground points past β.
  const IptCamera cam = thesis_rig();
  const LensPose l0{0.0, 0.0, CV_PI / 2}, l1{0.0, 0.02, CV_PI / 2};
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 0.5f);
  auto share_above_beta = [&](double range_m) {
    int above = 0;
    const int n = 400;
    for (int i = 0; i < n; ++i) {
      Track t = track_of(cam, l0, l1, {0.0, range_m, 0.0});
      t.a += cv::Point2f(noise(rng), noise(rng));
      t.b += cv::Point2f(noise(rng), noise(rng));
      if (discrepancy_m(cam, l0, l1, t.a, t.b) > 0.021) ++above;
    }
    return static_cast<double>(above) / n;
  };
  const double near = share_above_beta(0.8), far = share_above_beta(2.0);
  EXPECT_LT(near, 0.05);
  EXPECT_GT(far, 0.4);
}

TEST(IptClassifier, BandsMustBePairs) {
  ClassifierParams p;
  p.unclassified_bands_m = {0.02, 0.05, 0.1};
  EXPECT_EQ(p.validate().error().code, ErrorCode::inconsistent);
  p.unclassified_bands_m = {0.05, 0.02};
  EXPECT_EQ(p.validate().error().code, ErrorCode::inconsistent);
}

}  // namespace
}  // namespace visnav::ipt
