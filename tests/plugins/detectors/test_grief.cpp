// grief: pairs files (load, validation with file:line, crash-safe write) and the detector type
// (default = the shipped trained pattern, brief = star_brief's BRIEF, a loaded pattern changes the
// descriptor, bad file → error).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "error_expect.hpp"
#include "test_support.hpp"
#include "visnav/detectors/detector_types.hpp"
#include "visnav/detectors/grief.hpp"

namespace d = visnav::detectors;

namespace {

struct Tmp {
  std::filesystem::path dir;
  Tmp() {
    dir = std::filesystem::temp_directory_path() / ("visnav_grief_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
  }
  ~Tmp() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const auto p = (dir / name).string();
    std::ofstream(p) << text;
    return p;
  }
};

// A valid pairs file text: BRIEF's pattern for S = 48 with pair `bad_index` replaced by `bad`.
std::string pairs_text(int bad_index = -1, const std::string& bad = {}) {
  std::string s = "patch_size_px: 48\npairs:\n";
  const auto pattern = d::BriefExtractor::make_pattern(48);
  for (int i = 0; i < static_cast<int>(pattern.size()); ++i) {
    const auto& t = pattern[static_cast<std::size_t>(i)];
    if (i == bad_index) s += "  - " + bad + "\n";
    else s += "  - [" + std::to_string(t.x1) + ", " + std::to_string(t.y1) + ", " + std::to_string(t.x2) + ", " +
               std::to_string(t.y2) + "]\n";
  }
  return s;
}

}  // namespace

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(GriefPairs, WriteThenReadRoundTrips) {
  Tmp tmp;
  d::PairsFile f;
  f.patch_size_px = 48;
  f.pairs = d::BriefExtractor::make_pattern(48);
  f.pairs[7] = d::BriefTest{-20, 3, 4, 11};
  const auto path = (tmp.dir / "p.yaml").string();
  ASSERT_TRUE(d::write_pairs_file(path, f, {{"generation", "12"}, {"seed", "5"}}, "test").ok());
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  auto back = d::read_pairs_file(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->pairs.size(), 256u);
  EXPECT_EQ(back->pairs[7].x1, -20);
  EXPECT_EQ(back->pairs[7].y2, 11);
  EXPECT_EQ(back->pairs[100].x1, f.pairs[100].x1);
  ASSERT_TRUE(back->training.is_map());
  ASSERT_NE(back->training.find("generation"), nullptr);
  EXPECT_EQ(back->training.find("generation")->scalar(), "12");
}

TEST(GriefPairs, BadFilesNameFileLineAndPair) {
  Tmp tmp;
  struct Case {
    std::string text;
    int line;             // expected line in the message (0: no line check)
    const char* needle;   // expected text in the message
  };
  const Case cases[] = {
      {pairs_text(12, "[30, 0, 1, 1]"), 15, "pair 12: point (30, 0) is outside the patch disc"},
      {pairs_text(3, "[1, 2, 1, 2]"), 6, "pair 3 compares point (1, 2) with itself"},
      {pairs_text(200, "[1, 2, x, 2]"), 203, "pair 200: 'x' is not an integer"},
      {pairs_text(5, "[1, 2, 3]"), 8, "pair 5: expected [x1, y1, x2, y2]"},
      {"patch_size_px: 48\npairs:\n  - [1, 2, 3, 4]\n", 3, "expected exactly 256 pairs, got 1"},
      {"patch_size_px: 48\nbogus: 1\npairs: []\n", 2, "unknown key 'bogus'"},
      {"patch_size_px: 200\npairs: []\n", 1, "key 'patch_size_px'"},
      {"pairs: []\n", 0, "missing key 'patch_size_px'"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const auto path = tmp.write("bad" + std::to_string(k++) + ".yaml", c.text);
    auto r = d::read_pairs_file(path);
    ASSERT_FALSE(r.ok()) << c.needle;
    const std::string& m = r.error().message;
    EXPECT_NE(m.find(c.needle), std::string::npos) << m;
    if (c.line > 0) {
      EXPECT_NE(m.find(path + ":" + std::to_string(c.line) + ":"), std::string::npos) << m;
    }
  }
  auto missing = d::read_pairs_file((tmp.dir / "nope.yaml").string());
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"nope.yaml"}));
}

// The file that ships (config/detectors/grief_seasonal.yaml) parses, and the library's built-in
// copy is that file as it is now (a retrained file that was not rebuilt fails here).
TEST(GriefPairs, TheShippedPatternParsesAndIsBuiltIn) {
  const std::string path = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/detectors/grief_seasonal.yaml";
  auto file = d::read_pairs_file(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(file->patch_size_px, 48);
  ASSERT_EQ(file->pairs.size(), 256u);
  EXPECT_TRUE(file->training.is_map());  // trained, with its record

  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(std::string(d::seasonal_pairs_yaml()), text);

  auto built_in = d::seasonal_pairs();
  ASSERT_TRUE(built_in.ok()) << built_in.error().message;
  ASSERT_EQ(built_in->pairs.size(), 256u);
  int differs_from_brief = 0;
  const auto brief = d::BriefExtractor::make_pattern(48);
  for (std::size_t i = 0; i < 256; ++i) {
    const d::BriefTest& a = built_in->pairs[i];
    const d::BriefTest& b = brief[i];
    EXPECT_EQ(a.x1, file->pairs[i].x1);
    EXPECT_EQ(a.y2, file->pairs[i].y2);
    if (a.x1 != b.x1 || a.y1 != b.y1 || a.x2 != b.x2 || a.y2 != b.y2) ++differs_from_brief;
  }
  EXPECT_GT(differs_from_brief, 12);  // more than one generation's replacements
}

TEST(GriefPairs, TextErrorsNameTheLabelAndLine) {
  auto r = d::parse_pairs_text(pairs_text(12, "[30, 0, 1, 1]"), "mem.yaml");
  EXPECT_TRUE(fails_with(r, ErrorCode::out_of_range, At{"mem.yaml", 15}));
}

// grief without `pairs` uses the shipped pattern, from any working directory: its descriptors
// are the built-in file's, not BRIEF's; `pairs: brief` is exactly star_brief.
TEST(GriefDetector, DefaultIsTheShippedPatternFromAnyDirectory) {
  const cv::Mat img = d::testing::motorcycle_window(40, 10);
  if (img.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  Tmp tmp;
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(tmp.dir);  // nothing of the project here
  auto grief = d::create_detector("grief", d::make_params({{"target_keypoints", "300"}}));
  std::filesystem::current_path(cwd);
  ASSERT_TRUE(grief.ok()) << grief.error().message;
  const std::string path = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/detectors/grief_seasonal.yaml";
  auto from_file = d::create_detector("grief", d::make_params({{"target_keypoints", "300"}, {"pairs", path}}));
  auto star = d::create_detector("star_brief", d::make_params({{"target_keypoints", "300"}}));
  ASSERT_TRUE(from_file.ok() && star.ok());
  visnav::Features fg, ff, fs;
  ASSERT_TRUE((*grief)->detect(img, fg).ok());
  ASSERT_TRUE((*from_file)->detect(img, ff).ok());
  ASSERT_TRUE((*star)->detect(img, fs).ok());
  ASSERT_GT(fs.keypoints.size(), 100u);
  ASSERT_EQ(fg.keypoints.size(), fs.keypoints.size());
  ASSERT_EQ(ff.keypoints.size(), fs.keypoints.size());
  EXPECT_EQ(cv::norm(fg.descriptors, ff.descriptors, cv::NORM_HAMMING), 0.0);
  // The trained comparisons differ from BRIEF's, so do their bits (about half of a changed test's).
  EXPECT_GT(cv::norm(fg.descriptors, fs.descriptors, cv::NORM_HAMMING), 2.0 * static_cast<double>(fs.keypoints.size()));
}

TEST(GriefDetector, BriefIsStarBriefAndAPairsFileChangesTheDescriptor) {
  const cv::Mat img = d::testing::motorcycle_window(40, 10);
  if (img.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  Tmp tmp;
  auto star = d::create_detector("star_brief", d::make_params({{"target_keypoints", "300"}}));
  auto grief = d::create_detector("grief", d::make_params({{"target_keypoints", "300"}, {"pairs", "brief"}}));
  ASSERT_TRUE(star.ok() && grief.ok());
  visnav::Features fs, fg;
  ASSERT_TRUE((*star)->detect(img, fs).ok());
  ASSERT_TRUE((*grief)->detect(img, fg).ok());
  ASSERT_GT(fs.keypoints.size(), 100u);
  ASSERT_EQ(fs.keypoints.size(), fg.keypoints.size());
  EXPECT_EQ(cv::norm(fs.descriptors, fg.descriptors, cv::NORM_HAMMING), 0.0);

  // Swap the two points of every test: each bit flips (except where both smoothed values tie).
  d::PairsFile f;
  f.pairs = d::BriefExtractor::make_pattern(48);
  for (auto& t : f.pairs) t = d::BriefTest{t.x2, t.y2, t.x1, t.y1};
  const auto path = (tmp.dir / "swapped.yaml").string();
  ASSERT_TRUE(d::write_pairs_file(path, f).ok());
  auto swapped = d::create_detector("grief", d::make_params({{"target_keypoints", "300"}, {"pairs", path}}));
  ASSERT_TRUE(swapped.ok()) << swapped.error().message;
  visnav::Features fw;
  ASSERT_TRUE((*swapped)->detect(img, fw).ok());
  ASSERT_EQ(fw.keypoints.size(), fs.keypoints.size());
  const double bits = cv::norm(fs.descriptors, fw.descriptors, cv::NORM_HAMMING);
  EXPECT_GT(bits, 0.8 * 256 * static_cast<double>(fs.keypoints.size()));
}

TEST(GriefDetector, BadPairsFileIsAnErrorOnCreateAndOnReload) {
  Tmp tmp;
  const auto bad = tmp.write("bad.yaml", pairs_text(12, "[30, 0, 1, 1]"));
  auto made = d::create_detector("grief", d::make_params({{"pairs", bad}}));
  EXPECT_TRUE(fails_with(made, ErrorCode::out_of_range, At{bad, 15}));
  EXPECT_NE(made.error().message.find("pair 12"), std::string::npos) << made.error().message;  // content: which pair
  EXPECT_NE(made.error().message.find("grief"), std::string::npos) << made.error().message;

  // The file's patch size must match the detector's.
  const auto good = tmp.write("good.yaml", pairs_text());
  auto shipped_mismatch = d::create_detector("grief", d::make_params({{"patch_size_px", "32"}}));
  EXPECT_TRUE(fails_with(shipped_mismatch, ErrorCode::inconsistent));
  EXPECT_TRUE(d::create_detector("grief", d::make_params({{"patch_size_px", "32"}, {"pairs", "brief"}})).ok());
  auto mismatch = d::create_detector("grief", d::make_params({{"pairs", good}, {"patch_size_px", "32"}}));
  ASSERT_FALSE(mismatch.ok());
  EXPECT_NE(mismatch.error().message.find("patch_size_px 48"), std::string::npos) << mismatch.error().message;

  auto det = d::create_detector("grief", d::make_params({{"pairs", good}}));
  ASSERT_TRUE(det.ok()) << det.error().message;
  EXPECT_FALSE((*det)->reconfigure(d::make_params({{"pairs", bad}})).ok());
}
