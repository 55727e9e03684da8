// The detector plugins through the real loader: both .so files load, every type is created
// by its plugin factory, detects on a real photo, documents its params and reconfigures live.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"
#include "error_expect.hpp"

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

using visnav::PluginKind;
using visnav::PluginLoader;

struct TestHost {
  PluginLoader loader{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  visnav::StderrLogger logger{visnav::LogLevel::warn};
  visnav::ManualClock clock;
  visnav::RuntimeHost host{loader, logger, clock};

  /// Loads both detector libraries by name (not a scan: other plugins are not this test's business).
  void load_detectors() {
    for (const char* name : {"detector_star_brief", "detectors_opencv"}) {
      auto lib = loader.load_library(name);
      ASSERT_TRUE(lib.ok()) << lib.error().message;
    }
  }
};

visnav::ConfigNode params(std::initializer_list<std::pair<std::string, std::string>> entries) {
  visnav::ConfigNode node = visnav::ConfigNode::make_map({"detector.yaml", 1});
  int line = 2;
  for (const auto& [k, v] : entries) node.set(k, visnav::ConfigNode::make_scalar(v, {"detector.yaml", line++}));
  return node;
}

const std::vector<std::pair<std::string, std::string>> kTypes = {
    {"star_brief", "detector_star_brief"}, {"grief", "detector_star_brief"}, {"orb", "detectors_opencv"},
    {"agast_brief", "detectors_opencv"},
    {"fast_brief", "detectors_opencv"},    {"gftt_brief", "detectors_opencv"}, {"sift", "detectors_opencv"},
    {"akaze", "detectors_opencv"},         {"brisk", "detectors_opencv"}};

TEST(DetectorPlugins, BothLibrariesLoadAndProvideAllTypes) {
  TestHost h;
  for (const char* name : {"detector_star_brief", "detectors_opencv"}) {
    auto lib = h.loader.load_library(name);
    ASSERT_TRUE(lib.ok()) << lib.error().message;
    EXPECT_EQ((*lib)->kinds, std::vector<PluginKind>{PluginKind::detector});
    EXPECT_EQ((*lib)->abi_version, visnav::kPluginAbiVersion);
  }
  for (const auto& [type, library] : kTypes) {
    auto info = h.loader.find_type(PluginKind::detector, type);
    ASSERT_TRUE(info.ok()) << info.error().message;
    EXPECT_NE(info->library_path.find("libvisnav_" + library + ".so"), std::string::npos) << info->library_path;
    EXPECT_FALSE(info->description.empty());
    auto docs = h.loader.param_docs(PluginKind::detector, type);
    ASSERT_TRUE(docs.ok()) << docs.error().message;
    bool has_target = false;
    for (const auto& d : *docs) has_target = has_target || d.name == "target_keypoints";
    EXPECT_TRUE(has_target) << type;
  }
}

TEST(DetectorPlugins, EveryTypeIsCreatedThroughTheLoaderAndDetects) {
  cv::Mat photo = visnav::detectors::testing::motorcycle_window(30, 10);
  if (photo.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  TestHost h;
  h.load_detectors();
  for (const auto& [type, library] : kTypes) {
    auto det = h.loader.create<visnav::Detector>(type, params({{"target_keypoints", "200"}}), h.host);
    ASSERT_TRUE(det.ok()) << type << ": " << det.error().message;
    visnav::Features f;
    ASSERT_TRUE((*det)->detect(photo, f).ok()) << type;
    EXPECT_GT(f.keypoints.size(), 50U) << type;
    EXPECT_LE(f.keypoints.size(), 200U) << type;
    EXPECT_EQ(static_cast<int>(f.keypoints.size()), f.descriptors.rows) << type;
    EXPECT_EQ(f.norm, type == "sift" ? visnav::DescriptorNorm::l2 : visnav::DescriptorNorm::hamming) << type;
    // Live reload through the SDK interface.
    ASSERT_TRUE((*det)->reconfigure(params({{"target_keypoints", "80"}})).ok()) << type;
    ASSERT_TRUE((*det)->detect(photo, f).ok()) << type;
    EXPECT_LE(f.keypoints.size(), 80U) << type;
    // Bad input is an error, not a crash.
    EXPECT_FALSE((*det)->detect(cv::Mat(), f).ok()) << type;
  }
}

TEST(DetectorPlugins, ParamErrorsCarryTheConfigLocation) {
  TestHost h;
  h.load_detectors();
  auto det = h.loader.create<visnav::Detector>("star_brief", params({{"target_keypoints", "0"}}), h.host);
  EXPECT_TRUE(fails_with(det, ErrorCode::out_of_range, At{"detector.yaml", 2, "target_keypoints"}));
  auto orb = h.loader.create<visnav::Detector>("orb", params({{"max_size_px", "9"}}), h.host);
  EXPECT_TRUE(fails_with(orb, ErrorCode::unknown_key, At{"detector.yaml", 0, "max_size_px"}));
}

TEST(DetectorPlugins, HostCreatesDetectorsByType) {
  TestHost h;
  ASSERT_TRUE(h.loader.load_library("detector_star_brief").ok());
  auto det = h.host.create_detector("star_brief", visnav::ConfigNode{});
  ASSERT_TRUE(det.ok()) << det.error().message;
  EXPECT_EQ((*det)->norm(), visnav::DescriptorNorm::hamming);
}

}  // namespace
