// `visnav align` through the real plugin .so: the command is looked up in the loaded library's
// descriptor and run with a test HostServices whose detectors are OpenCV ORB.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "visnav/detectors/detector_types.hpp"
#include "visnav/detectors/grief.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"

namespace {

class OrbDetector final : public visnav::Detector {
 public:
  explicit OrbDetector(bool stateful = false) : stateful_(stateful) {}
  visnav::Status detect(const cv::Mat& image, visnav::Features& out) override {
    if (image.empty()) return visnav::fail("empty image");
    // stateful: fewer features every frame, like an adaptive threshold that drifts.
    if (stateful_) orb_->setMaxFeatures(std::max(50, 500 - 40 * frames_++));
    orb_->detectAndCompute(image, cv::noArray(), out.keypoints, out.descriptors);
    out.norm = visnav::DescriptorNorm::hamming;
    return visnav::ok();
  }
  [[nodiscard]] visnav::DescriptorNorm norm() const override { return visnav::DescriptorNorm::hamming; }

 private:
  bool stateful_;
  int frames_ = 0;
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
                                                                     const visnav::ConfigNode& params) override {
    requested.emplace_back(type);
    if (type == "star_brief" && with_star) {
      auto made = visnav::detectors::create_detector(type, params);
      if (!made) return std::move(made).error();
      return std::unique_ptr<visnav::Detector>(std::move(made).value());
    }
    if (type == "orb") return std::unique_ptr<visnav::Detector>(std::make_unique<OrbDetector>(stateful));
    return visnav::fail("no detector type '" + std::string(type) + "'");
  }
  std::vector<std::string> requested;
  bool stateful = false;
  bool with_star = false;  // provide the real star_brief (train-descriptor needs it)

 private:
  NullLogger logger_;
  ZeroClock clock_;
};

struct AlignFixture : ::testing::Test {
  void SetUp() override {
    loader = std::make_unique<visnav::PluginLoader>(std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR});
    auto lib = loader->load_library("feature_replay");
    ASSERT_TRUE(lib.ok()) << lib.error().message;
    for (const auto& c : loader->commands()) {
      if (c.name == "align") run = c.run;
      if (c.name == "train-descriptor") train = c.run;
    }
    ASSERT_NE(train, nullptr);
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
  int call(std::vector<std::string> args, std::string* out = nullptr) { return call_command(run, "align", args, out); }
  int call_command(int (*fn)(int, char**, visnav::HostServices&), const char* name, std::vector<std::string> args,
                   std::string* out = nullptr) {
    args.insert(args.begin(), name);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    testing::internal::CaptureStdout();
    const int rc = fn(static_cast<int>(args.size()), argv.data(), host);
    const std::string text = testing::internal::GetCapturedStdout();
    if (out != nullptr) *out = text;
    return rc;
  }
  std::unique_ptr<visnav::PluginLoader> loader;
  int (*run)(int, char**, visnav::HostServices&) = nullptr;
  int (*train)(int, char**, visnav::HostServices&) = nullptr;
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
  // default star_brief was asked first, then the orb fallback (then a fresh orb per image)
  // (star_brief is asked twice: with the default keypoints_per_mpx, then with the params as given)
  ASSERT_GE(host.requested.size(), 3u);
  EXPECT_EQ(host.requested[0], "star_brief");
  EXPECT_EQ(host.requested[1], "star_brief");
  EXPECT_EQ(host.requested[2], "orb");
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
    double offset = 0.0, confidence = 0.0, ambiguity = 0.0;
    int inliers = 0;
    ASSERT_TRUE(in >> a >> b >> offset >> inliers >> confidence >> ambiguity) << out;
    EXPECT_EQ(a, "ref.png");
    EXPECT_NEAR(offset, -s, 3.0) << b;
    EXPECT_GT(inliers, 20);
    EXPECT_GT(confidence, 0.5);
    EXPECT_LT(ambiguity, 0.3);
  }
  std::string a, b, offset, reason;
  ASSERT_TRUE(in >> a >> b >> offset >> reason);
  EXPECT_EQ(b, "missing.png");
  EXPECT_EQ(offset, "none");
  EXPECT_EQ(reason, "reason:");
}

// Detectors whose state carries over between frames (an adaptive threshold): the result of a pair
// must not depend on the pairs before it. The fake counts its frames and keeps fewer keypoints the
// more frames it has seen, as a drifting threshold would; align must use a fresh one per image.
TEST_F(AlignFixture, PairsAreIndependentOfOrder) {
  const cv::Mat img = fr_test::load_grey("astronaut.png");
  const cv::Mat cam = fr_test::load_grey("camera.png");
  if (img.empty() || cam.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  cv::imwrite((dir / "r1.png").string(), img(cv::Rect(80, 60, 340, 320)));
  cv::imwrite((dir / "s1.png").string(), img(cv::Rect(95, 60, 340, 320)));
  cv::imwrite((dir / "r2.png").string(), cam(cv::Rect(60, 80, 360, 300)));
  cv::imwrite((dir / "s2.png").string(), cam(cv::Rect(50, 80, 360, 300)));
  std::ofstream((dir / "ab.txt").string()) << "r1.png s1.png\nr2.png s2.png\n";
  std::ofstream((dir / "ba.txt").string()) << "r2.png s2.png\nr1.png s1.png\n";
  host.stateful = true;
  std::string ab, ba;
  EXPECT_EQ(call({"--pairs", (dir / "ab.txt").string(), "--detector", "orb"}, &ab), 0) << ab;
  EXPECT_EQ(call({"--pairs", (dir / "ba.txt").string(), "--detector", "orb"}, &ba), 0) << ba;
  auto lines = [](const std::string& text) {
    std::vector<std::string> v;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
  };
  const auto x = lines(ab), y = lines(ba);
  ASSERT_EQ(x.size(), 2u) << ab;
  ASSERT_EQ(y.size(), 2u) << ba;
  EXPECT_EQ(x[0], y[1]);
  EXPECT_EQ(x[1], y[0]);
}

TEST_F(AlignFixture, NoValidEstimatePrintsNoneWithAReasonAndFails) {
  const cv::Mat img = fr_test::load_grey("astronaut.png");
  const cv::Mat cam = fr_test::load_grey("camera.png");
  if (img.empty() || cam.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  // Two unrelated photos: no consistent offset.
  cv::imwrite((dir / "a.png").string(), img(cv::Rect(80, 60, 340, 320)));
  cv::imwrite((dir / "b.png").string(), cam(cv::Rect(60, 80, 340, 320)));
  std::string out;
  EXPECT_EQ(call({(dir / "a.png").string(), (dir / "b.png").string(), "--detector", "orb", "--set", "min_inliers=40",
                  "--set", "full_confidence_inliers=40"},
                 &out),
            1);
  EXPECT_EQ(out.rfind("offset_px none ", 0), 0u) << out;
  EXPECT_NE(out.find("reason: "), std::string::npos) << out;
  // In a labelled pairs file the pair counts as wrong, and the summary says so.
  std::ofstream((dir / "p.txt").string()) << "a.png b.png 0\na.png a.png 0\n";
  EXPECT_EQ(call({"--pairs", (dir / "p.txt").string(), "--detector", "orb", "--set", "min_inliers=40", "--set",
                  "full_confidence_inliers=40"},
                 &out),
            1);
  EXPECT_NE(out.find("a.png b.png none reason: "), std::string::npos) << out;
  EXPECT_NE(out.find("# pairs 2 valid 1 wrong 1 error_rate_pct 50.0"), std::string::npos) << out;
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

// train-descriptor through the plugin: writes a loadable pairs file, resumes to the same result
// as an uninterrupted run, and names FILE:LINE for a bad pairs list.
TEST_F(AlignFixture, TrainDescriptorWritesResumesAndReportsBadLines) {
  const cv::Mat img = fr_test::load_grey("astronaut.png");
  const cv::Mat cam = fr_test::load_grey("camera.png");
  if (img.empty() || cam.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  host.with_star = true;
  std::ofstream list((dir / "train.txt").string());
  int k = 0;
  for (const cv::Mat* src : {&img, &cam}) {
    for (int shift : {-20, 25}) {
      std::string a = "a", b = "b";  // (append: GCC 12 warns falsely on "x" + std::string + "y")
      a.append(std::to_string(k)).append(".png");
      b.append(std::to_string(k)).append(".png");
      cv::imwrite((dir / a).string(), (*src)(cv::Rect(60, 60, 360, 300)));
      cv::Mat moved = (*src)(cv::Rect(60 - shift, 60, 360, 300)) * 0.7 + 30;  // darker, lower contrast
      cv::imwrite((dir / b).string(), moved);
      list << a << ' ' << b << ' ' << shift << '\n';
      ++k;
    }
  }
  list.close();
  const auto full = (dir / "full.yaml").string(), part = (dir / "part.yaml").string();
  const std::string pairs = (dir / "train.txt").string();
  std::string out;
  ASSERT_EQ(call_command(train, "train-descriptor", {"--pairs", pairs, "-o", full, "--generations", "4", "--seed", "3",
                                                    "--param", "target_keypoints=200"},
                         &out),
            0)
      << out;
  EXPECT_NE(out.find("trained generations 4 correct "), std::string::npos) << out;
  ASSERT_EQ(call_command(train, "train-descriptor", {"--pairs", pairs, "-o", part, "--generations", "2", "--seed", "3",
                                                    "--param", "target_keypoints=200"}),
            0);
  ASSERT_EQ(call_command(train, "train-descriptor", {"--pairs", pairs, "-o", part, "--generations", "4", "--seed", "3",
                                                    "--param", "target_keypoints=200", "--resume"}),
            0);
  auto a = visnav::detectors::read_pairs_file(full);
  auto b = visnav::detectors::read_pairs_file(part);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  ASSERT_NE(a->training.find("generation"), nullptr);
  EXPECT_EQ(a->training.find("generation")->scalar(), "4");
  EXPECT_EQ(b->training.find("generation")->scalar(), "4");
  for (std::size_t i = 0; i < a->pairs.size(); ++i) {
    EXPECT_EQ(a->pairs[i].x1, b->pairs[i].x1) << i;
    EXPECT_EQ(a->pairs[i].y2, b->pairs[i].y2) << i;
  }
  // Resuming with another seed is refused; a bad line is reported with FILE:LINE.
  EXPECT_EQ(call_command(train, "train-descriptor", {"--pairs", pairs, "-o", part, "--generations", "5", "--seed", "4",
                                                    "--resume"}),
            1);
  std::ofstream((dir / "bad.txt").string()) << "a0.png b0.png 3\n# comment\na1.png b1.png twelve\n";
  testing::internal::CaptureStderr();
  EXPECT_EQ(call_command(train, "train-descriptor", {"--pairs", (dir / "bad.txt").string(), "-o", full}), 1);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("bad.txt:3: SHIFT_PX 'twelve' is not a number"), std::string::npos) << err;
  EXPECT_EQ(call_command(train, "train-descriptor", {"--pairs", pairs}), 2);  // no -o
}
