// Tests of every detector type through the core factory: input handling, params, live
// reconfiguration, adaptive threshold on a real photo, and shift recovery by matching.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/detectors/detector_types.hpp"
#include "error_expect.hpp"

namespace visnav::detectors {
using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

using testing::median;

class EveryType : public ::testing::TestWithParam<std::string> {};

std::unique_ptr<DetectorBase> make(const std::string& type, const ConfigNode& params = ConfigNode{}) {
  auto made = create_detector(type, params);
  EXPECT_TRUE(made.ok()) << (made.ok() ? "" : made.error().message);
  return made.ok() ? std::move(made).value() : nullptr;
}

TEST_P(EveryType, RejectsBadImagesAndSurvivesBlankAndTinyOnes) {
  auto det = make(GetParam());
  ASSERT_TRUE(det);
  Features f;
  auto st = det->detect(cv::Mat(), f);
  EXPECT_TRUE(fails_with(st, ErrorCode::invalid_value));
  st = det->detect(cv::Mat(48, 64, CV_16UC1, cv::Scalar(3)), f);
  EXPECT_TRUE(fails_with(st, ErrorCode::invalid_value));
  EXPECT_NE(st.error().message.find("CV_16UC1"), std::string::npos) << st.error().message;  // names the type
  EXPECT_TRUE(fails_with(det->detect(cv::Mat(48, 64, CV_32FC3), f), ErrorCode::invalid_value));
  EXPECT_TRUE(fails_with(det->detect(cv::Mat(48, 64, CV_8UC2, cv::Scalar(1, 2)), f), ErrorCode::invalid_value));

  for (const cv::Mat& blank : {cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90))}) {
    ASSERT_TRUE(det->detect(blank, f).ok());
    EXPECT_TRUE(f.keypoints.empty());
    EXPECT_EQ(f.descriptors.rows, 0);
  }
  for (int side : {1, 2, 7, 16, 31, 32, 33, 60}) {
    cv::Mat tiny(side, side + 3, CV_8UC3);
    cv::randu(tiny, 0, 256);
    ASSERT_TRUE(det->detect(tiny, f).ok()) << side;
    EXPECT_EQ(static_cast<int>(f.keypoints.size()), f.descriptors.rows);
  }
  EXPECT_EQ(f.norm, det->norm());
}

TEST_P(EveryType, DescribesARealPhotoGreyBgrAndBgra) {
  cv::Mat bgr = testing::motorcycle_window(40, 10);
  if (bgr.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  auto det = make(GetParam(), make_params({{"target_keypoints", "300"}}));
  ASSERT_TRUE(det);
  cv::Mat grey;
  cv::Mat bgra;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  for (const cv::Mat* img : {&bgr, &grey, &bgra}) {
    Features f;
    ASSERT_TRUE(det->detect(*img, f).ok());
    EXPECT_GT(f.keypoints.size(), 50U);
    EXPECT_LE(f.keypoints.size(), 300U);
    EXPECT_EQ(static_cast<int>(f.keypoints.size()), f.descriptors.rows);
    EXPECT_EQ(f.norm, det->norm());
    EXPECT_EQ(f.descriptors.type(), det->norm() == DescriptorNorm::hamming ? CV_8U : CV_32F);
  }
}

// Frames until the kept count is within [0.85, 1] × target with a raw count near the aim.
int frames_to_target(DetectorBase& det, const cv::Mat& image, int target) {
  Features f;
  for (int frame = 1; frame <= 12; ++frame) {
    EXPECT_TRUE(det.detect(image, f).ok());
    const double kept = static_cast<double>(f.keypoints.size());
    // The raw count itself must approach the aim (not just be clipped from far above).
    if (kept >= 0.85 * target && kept <= target && det.last_raw_count() <= 1.15 * 1.2 * target) return frame;
  }
  return 99;
}

TEST_P(EveryType, AdaptiveThresholdReachesTheTargetOnARealPhoto) {
  cv::Mat bgr = testing::motorcycle_window(60, 5);
  if (bgr.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  const auto docs = detector_param_docs(GetParam());
  ASSERT_TRUE(docs.ok());
  std::string min_t;
  std::string max_t;
  for (const auto& d : *docs) {
    if (d.name == "min_threshold") min_t = d.default_value;
    if (d.name == "max_threshold") max_t = d.default_value;
  }
  // From the default threshold: a few frames.
  {
    auto det = make(GetParam(), make_params({{"target_keypoints", "400"}}));
    ASSERT_TRUE(det);
    const int frames = frames_to_target(*det, bgr, 400);
    EXPECT_LE(frames, 6) << GetParam() << ": raw " << det->last_raw_count() << " threshold " << det->threshold();
    // ... and stays there.
    Features f;
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(det->detect(bgr, f).ok());
      EXPECT_GE(f.keypoints.size(), 0.85 * 400) << GetParam();
    }
  }
  // From either clamp (hundreds of times off): still bounded.
  for (const std::string& t0 : {min_t, max_t}) {
    auto det = make(GetParam(), make_params({{"target_keypoints", "400"}, {"threshold", t0}}));
    ASSERT_TRUE(det);
    const int frames = frames_to_target(*det, bgr, 400);
    EXPECT_LE(frames, 10) << GetParam() << " from " << t0 << ": raw " << det->last_raw_count() << " threshold "
                          << det->threshold();
  }
}

TEST_P(EveryType, ReconfigureChangesTargetAndKeepsTheOldConfigOnError) {
  cv::Mat bgr = testing::motorcycle_window(0, 0);
  if (bgr.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  auto det = make(GetParam(), make_params({{"target_keypoints", "400"}}));
  ASSERT_TRUE(det);
  Features f;
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(det->detect(bgr, f).ok());
  const double adapted = det->threshold();
  ASSERT_TRUE(det->reconfigure(make_params({{"target_keypoints", "150"}})).ok());
  EXPECT_EQ(det->target_keypoints(), 150);
  EXPECT_DOUBLE_EQ(det->threshold(), adapted);  // adaptation survives a reload
  ASSERT_TRUE(det->detect(bgr, f).ok());
  EXPECT_LE(f.keypoints.size(), 150U);
  EXPECT_GE(f.keypoints.size(), 100U);

  auto bad = det->reconfigure(make_params({{"target_keypoints", "-3"}}));
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, visnav::ErrorCode::out_of_range) << bad.error().message;
  EXPECT_EQ(bad.error().where.key, "target_keypoints") << bad.error().message;
  EXPECT_EQ(det->target_keypoints(), 150);
  bad = det->reconfigure(make_params({{"no_such_key", "1"}}));
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, visnav::ErrorCode::unknown_key) << bad.error().message;
  EXPECT_EQ(bad.error().where.key, "no_such_key") << bad.error().message;
  bad = det->reconfigure(make_params({{"min_threshold", "50"}, {"max_threshold", "40"}, {"threshold", "45"}}));
  EXPECT_FALSE(bad.ok());
}

TEST_P(EveryType, RecoversAKnownHorizontalShiftByMatching) {
  // Two 640×480 windows of one real photo, 17 px apart horizontally: scene content sits 17 px
  // further left in B. Matching must give a median displacement of −17 ± 3 px, also when B's
  // brightness and contrast change.
  cv::Mat a = testing::motorcycle_window(40, 8);
  cv::Mat b = testing::motorcycle_window(57, 8);
  if (a.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  cv::Mat b_changed;
  b.convertTo(b_changed, -1, 0.75, 40);
  for (const cv::Mat* target : {&b, &b_changed}) {
    auto det = make(GetParam(), make_params({{"target_keypoints", "500"}}));
    ASSERT_TRUE(det);
    Features fa;
    Features fb;
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(det->detect(a, fa).ok());  // let the threshold settle
    ASSERT_TRUE(det->detect(*target, fb).ok());
    const auto matches = testing::ratio_matches(fa, fb, 0.8);
    ASSERT_GE(matches.size(), 40U) << GetParam();
    std::vector<double> dx;
    std::vector<double> dy;
    for (const auto& m : matches) {
      dx.push_back(fb.keypoints[static_cast<std::size_t>(m.b)].pt.x - fa.keypoints[static_cast<std::size_t>(m.a)].pt.x);
      dy.push_back(fb.keypoints[static_cast<std::size_t>(m.b)].pt.y - fa.keypoints[static_cast<std::size_t>(m.a)].pt.y);
    }
    EXPECT_NEAR(median(dx), -17.0, 3.0) << GetParam() << (target == &b ? "" : " (brightness/contrast changed)");
    EXPECT_NEAR(median(dy), 0.0, 3.0) << GetParam();
  }
}

INSTANTIATE_TEST_SUITE_P(Detectors, EveryType, ::testing::ValuesIn(detector_type_names()),
                         [](const auto& test_info) { return test_info.param; });

TEST(DetectorTypes, AllNineTypesExist) {
  const std::vector<std::string> expected = {"star_brief", "grief", "orb",   "agast_brief", "fast_brief",
                                             "gftt_brief", "sift",  "akaze", "brisk"};
  EXPECT_EQ(detector_type_names(), expected);
  auto unknown = create_detector("surf");
  EXPECT_TRUE(fails_with(unknown, ErrorCode::not_found));
  EXPECT_NE(unknown.error().message.find("star_brief"), std::string::npos) << unknown.error().message;  // lists the known
}

TEST(DetectorTypes, ParamErrorsNameTheKeyAndLocation) {
  ConfigNode params = ConfigNode::make_map({"robot.yaml", 10});
  params.set("target_keypoints", ConfigNode::make_scalar("lots", {"robot.yaml", 11}));
  auto made = create_detector("star_brief", params);
  ASSERT_FALSE(made.ok());
  EXPECT_EQ(made.error().code, visnav::ErrorCode::invalid_value) << made.error().message;
  EXPECT_EQ(made.error().where.file, "robot.yaml") << made.error().message;
  EXPECT_EQ(made.error().where.line, 11) << made.error().message;
  EXPECT_EQ(made.error().where.key, "target_keypoints") << made.error().message;

  auto brisk = create_detector("brisk", make_params({{"upright", "true"}}));
  EXPECT_TRUE(fails_with(brisk, ErrorCode::inconsistent, visnav::test::key_only("upright")));
  EXPECT_FALSE(create_detector("star_brief", make_params({{"threshold", "1"}, {"min_threshold", "2"}})).ok());
  EXPECT_FALSE(create_detector("star_brief", make_params({{"suppress_nonmax_size_px", "4"}})).ok());
  EXPECT_FALSE(create_detector("agast_brief", make_params({{"agast_type", "OAST_5_5"}})).ok());
  EXPECT_FALSE(create_detector("gftt_brief", make_params({{"block_size_px", "4"}})).ok());
}

TEST(DetectorTypes, EveryParamIsDocumented) {
  for (const auto& type : detector_type_names()) {
    auto docs = detector_param_docs(type);
    ASSERT_TRUE(docs.ok());
    for (const auto& d : *docs) {
      EXPECT_FALSE(d.description.empty()) << type << "." << d.name;
      EXPECT_FALSE(d.default_value.empty()) << type << "." << d.name;
    }
    // Defaults are valid.
    EXPECT_TRUE(create_detector(type).ok()) << type;
  }
}

TEST(DetectorTypes, UprightVersusOriented) {
  cv::Mat bgr = testing::motorcycle_window(20, 0);
  if (bgr.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  for (const char* type : {"star_brief", "agast_brief", "fast_brief", "gftt_brief", "orb", "sift", "akaze"}) {
    auto upright = make(type, make_params({{"upright", "true"}}));
    auto oriented = make(type, make_params({{"upright", "false"}}));
    ASSERT_TRUE(upright && oriented);
    Features fu;
    Features fo;
    ASSERT_TRUE(upright->detect(bgr, fu).ok());
    ASSERT_TRUE(oriented->detect(bgr, fo).ok());
    ASSERT_FALSE(fu.keypoints.empty());
    ASSERT_FALSE(fo.keypoints.empty());
    int distinct_angles = 0;
    for (const auto& kp : fo.keypoints) {
      EXPECT_GE(kp.angle, 0.0F) << type;
      EXPECT_LT(kp.angle, 360.0F) << type;
      if (std::abs(kp.angle - fo.keypoints.front().angle) > 1.0F) ++distinct_angles;
    }
    EXPECT_GT(distinct_angles, static_cast<int>(fo.keypoints.size()) / 4) << type;
    // AKAZE's upright mode keeps OpenCV's angle field; the others report a constant angle.
    if (std::string(type) != "akaze") {
      for (const auto& kp : fu.keypoints) EXPECT_TRUE(kp.angle == 0.0F || kp.angle == -1.0F) << type << " " << kp.angle;
    }
  }
}

TEST(DetectorTypes, KeptFeaturesAreNotOverwrittenByTheNextFrame) {
  cv::Mat a = testing::motorcycle_window(0, 0);
  cv::Mat b = testing::motorcycle_window(100, 20);
  if (a.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  auto det = make("star_brief", make_params({{"target_keypoints", "200"}, {"adaptive_threshold", "false"}, {"threshold", "10"}}));
  ASSERT_TRUE(det);
  Features f;
  ASSERT_TRUE(det->detect(a, f).ok());
  const cv::Mat kept = f.descriptors;  // shallow: shares the buffer
  const cv::Mat snapshot = kept.clone();
  ASSERT_TRUE(det->detect(b, f).ok());
  EXPECT_EQ(cv::norm(kept, snapshot, cv::NORM_HAMMING), 0.0);
}

}  // namespace
}  // namespace visnav::detectors
