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
#include <opencv2/imgproc.hpp>

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

namespace {

// A textured picture drawn with its own generator: random grey rectangles and discs, lightly
// blurred, so ORB finds hundreds of distinct corners and any crop of it aligns unambiguously.
cv::Mat textured_picture(int seed) {
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  cv::Mat img(400, 800, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 700; ++i) {
    const int x = rng.uniform(0, 800);
    const int y = rng.uniform(0, 400);
    const int size = rng.uniform(3, 25);
    const int grey = rng.uniform(0, 256);
    if (rng.uniform(0, 2) == 0)
      cv::rectangle(img, cv::Rect(x, y, size, rng.uniform(3, 25)), cv::Scalar(grey), cv::FILLED);
    else
      cv::circle(img, cv::Point(x, y), size / 2 + 1, cv::Scalar(grey), cv::FILLED);
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  return img;
}

std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> row;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) row.push_back(cell);
    if (!line.empty() && line.back() == ',') row.emplace_back();
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

// Issue 36: the labelled-pair protocol of GRIEF. Four crops of a generated texture with known
// shifts (right), a pair of blank images (no features: refused), and a correctly aligned pair
// whose label is 170 px off (answered, wrong). Error rate counting `none` as wrong 2/6, refusal
// 1/6, error among answered 1/5; the tolerance is a flag.
TEST_F(AlignFixture, PairsFileReportsTheThreeRatesOfTheGriefProtocol) {
  const cv::Mat img = textured_picture(36);
  std::ofstream pairs(dir / "labelled.txt");
  cv::imwrite((dir / "ref.png").string(), img(cv::Rect(200, 50, 340, 300)));
  for (int s : {-40, -10, 15, 45}) {
    std::string name = "s";
    name.append(std::to_string(s + 100)).append(".png");
    cv::imwrite((dir / name).string(), img(cv::Rect(200 + s, 50, 340, 300)));
    pairs << "ref.png " << name << ' ' << -s << '\n';  // B cut s px right: the scene sits s px left
  }
  cv::imwrite((dir / "blank.png").string(), cv::Mat(300, 340, CV_8UC1, cv::Scalar(128)));
  pairs << "blank.png blank.png 0\n";
  cv::imwrite((dir / "m20.png").string(), img(cv::Rect(220, 50, 340, 300)));
  pairs << "ref.png m20.png 150\n";  // true offset -20
  pairs.close();
  const std::string file = (dir / "labelled.txt").string();
  const auto csv = dir / "pairs.csv", curve = dir / "curve.csv";
  std::string out;
  EXPECT_EQ(call({"--pairs", file, "--detector", "orb", "--csv", csv.string(), "--gate-curve", curve.string()}, &out),
            1)
      << out;  // the blank pair has no estimate
  EXPECT_NE(out.find("blank.png blank.png none reason: no matches passed the gates"), std::string::npos) << out;
  EXPECT_NE(out.find("# pairs 6 valid 5 wrong 2 error_rate_pct 33.3 tolerance_px 35.0 refused 1 refusal_rate_pct 16.7 "
                     "answered_wrong 1 answered_error_rate_pct 20.0\n"),
            std::string::npos)
      << out;
  // The tolerance is a flag: 200 px accepts the mislabelled pair.
  EXPECT_EQ(call({"--pairs", file, "--detector", "orb", "--tolerance-px", "200"}, &out), 1);
  EXPECT_NE(out.find("# pairs 6 valid 5 wrong 1 error_rate_pct 16.7 tolerance_px 200.0 refused 1 refusal_rate_pct 16.7 "
                     "answered_wrong 0 answered_error_rate_pct 0.0\n"),
            std::string::npos)
      << out;

  // Per-pair CSV: header + 6 rows; the blank pair not valid, the mislabelled one not correct.
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), 7u);
  ASSERT_EQ(rows[0].size(), 12u);
  EXPECT_EQ(rows[0][0], "a");
  EXPECT_EQ(rows[0][10], "correct");
  int correct = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 12u) << i;
    correct += rows[i][10] == "1" ? 1 : 0;
  }
  EXPECT_EQ(correct, 4);
  EXPECT_EQ(rows[5][0], "blank.png");
  EXPECT_EQ(rows[5][8], "0");
  EXPECT_EQ(rows[6][1], "m20.png");
  EXPECT_EQ(rows[6][8], "1");
  EXPECT_EQ(rows[6][10], "0");
  EXPECT_NEAR(std::stod(rows[6][3]), -20.0, 3.0);
}

// Issue 36: the gate curve. 21 thresholds 0..1; coverage never grows with the gate; the point at
// a gate is what `--set min_confidence=` gives at that gate (here 0.25 and 0.5), and align's
// default is the calibrated gate 0.075 (docs/feature_replay.md section 7), not the SDK's 0.25.
TEST_F(AlignFixture, GateCurveSweepsTheConfidenceThreshold) {
  const cv::Mat img = textured_picture(36);
  std::ofstream pairs(dir / "labelled.txt");
  cv::imwrite((dir / "ref.png").string(), img(cv::Rect(200, 50, 340, 300)));
  for (int s : {-30, 25}) {
    std::string name = "s";
    name.append(std::to_string(s + 100)).append(".png");
    cv::imwrite((dir / name).string(), img(cv::Rect(200 + s, 50, 340, 300)));
    pairs << "ref.png " << name << ' ' << -s << '\n';
  }
  // A weak pair: a small crop of the texture against a larger one (few shared features).
  cv::Mat small = cv::Mat(300, 340, CV_8UC1, cv::Scalar(128));
  img(cv::Rect(260, 120, 60, 60)).copyTo(small(cv::Rect(140, 120, 60, 60)));
  cv::imwrite((dir / "small.png").string(), small);
  pairs << "ref.png small.png 0\n";
  cv::imwrite((dir / "blank.png").string(), cv::Mat(300, 340, CV_8UC1, cv::Scalar(128)));
  pairs << "ref.png blank.png 0\n";
  pairs.close();
  const std::string file = (dir / "labelled.txt").string();
  const auto curve = dir / "curve.csv";
  std::string out;
  call({"--pairs", file, "--detector", "orb", "--gate-curve", curve.string()}, &out);
  const auto rows = read_csv(curve);
  ASSERT_EQ(rows.size(), 22u);
  ASSERT_EQ(rows[0].size(), 10u);
  EXPECT_EQ(rows[0][2], "answered");
  EXPECT_EQ(rows[0][3], "coverage");
  EXPECT_EQ(rows[0][5], "precision");
  EXPECT_EQ(rows[1][0], "0.0000");
  EXPECT_EQ(rows[21][0], "1.0000");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 10u) << i;
    EXPECT_EQ(rows[i][1], "4");
    if (i > 1) {
      EXPECT_LE(std::stod(rows[i][3]), std::stod(rows[i - 1][3])) << i;
    }
  }
  EXPECT_LE(std::stoi(rows[1][2]), 3);  // the blank pair is never answered
  EXPECT_GE(std::stoi(rows[1][2]), 2);
  auto summary_answered = [&](const std::string& text) {
    const auto at = text.find("# pairs 4 valid ");
    return at == std::string::npos ? -1 : std::stoi(text.substr(at + 16));
  };
  ASSERT_EQ(rows[6][0], "0.2500");
  call({"--pairs", file, "--detector", "orb", "--set", "min_confidence=0.25"}, &out);
  EXPECT_EQ(summary_answered(out), std::stoi(rows[6][2])) << out;
  ASSERT_EQ(rows[11][0], "0.5000");
  call({"--pairs", file, "--detector", "orb", "--set", "min_confidence=0.5"}, &out);
  EXPECT_EQ(summary_answered(out), std::stoi(rows[11][2])) << out;
  // The default gate: the 0.075 point of a 40-step curve.
  call({"--pairs", file, "--detector", "orb", "--gate-curve", curve.string(), "--gate-steps", "40"}, &out);
  const auto fine = read_csv(curve);
  ASSERT_EQ(fine.size(), 42u);
  ASSERT_EQ(fine[4][0], "0.0750");
  EXPECT_EQ(summary_answered(out), std::stoi(fine[4][2])) << out;
  // Bad flag values are usage errors; an unwritable curve fails before any pair is aligned.
  EXPECT_EQ(call({"--pairs", file, "--gate-steps", "0"}), 2);
  EXPECT_EQ(call({"--pairs", file, "--detector", "orb", "--gate-curve", (dir / "no" / "such" / "c.csv").string()}), 2);
  EXPECT_EQ(call({"a.png", "b.png", "--gate-curve", curve.string()}), 2);  // needs --pairs
}
