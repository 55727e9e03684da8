// `visnav align` through the real plugin .so: the command is looked up in the loaded library's
// descriptor and run with a test HostServices whose detectors are OpenCV ORB.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"

namespace {

class OrbDetector final : public visnav::Detector {
 public:
  visnav::Status detect(const cv::Mat& image, visnav::Features& out) override {
    if (image.empty()) return visnav::fail("empty image");
    orb_->detectAndCompute(image, cv::noArray(), out.keypoints, out.descriptors);
    out.norm = visnav::DescriptorNorm::hamming;
    return visnav::ok();
  }
  [[nodiscard]] visnav::DescriptorNorm norm() const override { return visnav::DescriptorNorm::hamming; }

 private:
  cv::Ptr<cv::ORB> orb_ = cv::ORB::create(500);
};

class NullLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel, std::string_view, std::string_view) override {}
};
class ZeroClock final : public visnav::Clock {
 public:
  [[nodiscard]] double now_s() const override { return 0.0; }
};

class TestHost final : public visnav::HostServices {
 public:
  visnav::Logger& logger() override { return logger_; }
  const visnav::Clock& clock() override { return clock_; }
  visnav::Result<std::unique_ptr<visnav::Detector>> create_detector(std::string_view type,
                                                                     const visnav::ConfigNode&) override {
    requested.emplace_back(type);
    if (type == "orb") return std::unique_ptr<visnav::Detector>(std::make_unique<OrbDetector>());
    return visnav::fail("no detector type '" + std::string(type) + "'");
  }
  std::vector<std::string> requested;

 private:
  NullLogger logger_;
  ZeroClock clock_;
};

struct AlignFixture : ::testing::Test {
  void SetUp() override {
    loader = std::make_unique<visnav::PluginLoader>(std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR});
    auto lib = loader->load_library("feature_replay");
    ASSERT_TRUE(lib.ok()) << lib.error().message;
    for (const auto& c : loader->commands())
      if (c.name == "align") run = c.run;
    ASSERT_NE(run, nullptr);
    std::string leaf = "visnav_align_";
    leaf.append(std::to_string(::getpid()));
    dir = std::filesystem::temp_directory_path() / leaf;
    std::filesystem::create_directories(dir);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  int call(std::vector<std::string> args, std::string* out = nullptr) {
    args.insert(args.begin(), "align");
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    testing::internal::CaptureStdout();
    const int rc = run(static_cast<int>(args.size()), argv.data(), host);
    const std::string text = testing::internal::GetCapturedStdout();
    if (out != nullptr) *out = text;
    return rc;
  }
  std::unique_ptr<visnav::PluginLoader> loader;
  int (*run)(int, char**, visnav::HostServices&) = nullptr;
  TestHost host;
  std::filesystem::path dir;
};

}  // namespace

TEST_F(AlignFixture, SinglePairPrintsTheOffsetAndDraws) {
  const cv::Mat img = fr_test::load_grey("camera.png");
  if (img.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  // B is cut 21 px further right: the scene sits 21 px further left in B -> offset -21.
  cv::imwrite((dir / "a.png").string(), img(cv::Rect(60, 80, 360, 300)));
  cv::imwrite((dir / "b.png").string(), img(cv::Rect(81, 80, 360, 300)));
  std::string out;
  const auto draw = (dir / "draw.png").string();
  ASSERT_EQ(call({(dir / "a.png").string(), (dir / "b.png").string(), "--draw", draw}, &out), 0) << out;
  std::istringstream in(out);
  std::string key;
  double offset = 0.0;
  in >> key >> offset;
  EXPECT_EQ(key, "offset_px");
  EXPECT_NEAR(offset, -21.0, 3.0) << out;
  // default star_brief was asked first, then the orb fallback
  ASSERT_EQ(host.requested.size(), 2u);
  EXPECT_EQ(host.requested[0], "star_brief");
  EXPECT_EQ(host.requested[1], "orb");
  const cv::Mat picture = cv::imread(draw);
  ASSERT_FALSE(picture.empty());
  EXPECT_EQ(picture.cols, 720);
  EXPECT_GT(picture.rows, 300);
}

TEST_F(AlignFixture, PairsFile) {
  const cv::Mat img = fr_test::load_grey("astronaut.png");
  if (img.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  const int shifts[] = {-30, 0, 12};
  std::ofstream pairs(dir / "pairs.txt");
  pairs << "# reference shifted\n\n";
  cv::imwrite((dir / "ref.png").string(), img(cv::Rect(80, 60, 340, 320)));
  for (int s : shifts) {
    std::string name = std::to_string(s + 100);
    name.append(".png");
    cv::imwrite((dir / name).string(), img(cv::Rect(80 + s, 60, 340, 320)));
    pairs << "ref.png " << name << "\n";
  }
  pairs << "ref.png missing.png\n";
  pairs.close();
  std::string out;
  EXPECT_EQ(call({"--pairs", (dir / "pairs.txt").string(), "--detector", "orb"}, &out), 1);  // one pair fails
  std::istringstream in(out);
  for (int s : shifts) {
    std::string a, b;
    double offset = 0.0;
    int inliers = 0;
    ASSERT_TRUE(in >> a >> b >> offset >> inliers) << out;
    EXPECT_EQ(a, "ref.png");
    EXPECT_NEAR(offset, -s, 3.0) << b;
    EXPECT_GT(inliers, 20);
  }
  std::string a, b, offset;
  ASSERT_TRUE(in >> a >> b >> offset);
  EXPECT_EQ(b, "missing.png");
  EXPECT_EQ(offset, "nan");
}

TEST_F(AlignFixture, UsageErrors) {
  EXPECT_EQ(call({}), 2);
  EXPECT_EQ(call({"a.png"}), 2);
  EXPECT_EQ(call({"a.png", "b.png", "--bogus"}), 2);
  EXPECT_EQ(call({"a.png", "b.png", "--set", "bin_count=40"}), 2);
  EXPECT_EQ(call({"a.png", "b.png", "--detector", "nope"}), 2);  // explicit detector: no fallback
  EXPECT_EQ(call({"/nonexistent/a.png", "/nonexistent/b.png", "--detector", "orb"}), 1);
  std::string out;
  EXPECT_EQ(call({"--help"}, &out), 0);
  EXPECT_NE(out.find("--pairs"), std::string::npos);
}
