// The path_following plugin loaded through the real loader: descriptor, and the `pathseg`
// command run end to end on a synthetic image (prints v, ω, area share; draws the stages).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "synthetic.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"

namespace fs = std::filesystem;
namespace pft = visnav::path_following::testing;

namespace {

struct PluginFixture : ::testing::Test {
  void SetUp() override {
    auto lib = loader.load_library("path_following");
    ASSERT_TRUE(lib.ok()) << lib.error().message;
    info = *lib;
    for (const auto& c : loader.commands())
      if (c.name == "pathseg") pathseg = c;
    dir = fs::path(VISNAV_TEST_BINARY_DIR) / "test_output" / "path_following";
    fs::create_directories(dir);
  }

  int run(std::vector<std::string> args) {
    args.insert(args.begin(), "pathseg");
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    return pathseg.run(static_cast<int>(argv.size()), argv.data(), host);
  }

  visnav::PluginLoader loader{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  visnav::StderrLogger logger{visnav::LogLevel::warn};
  visnav::ManualClock clock;
  visnav::RuntimeHost host{loader, logger, clock};
  const visnav::PluginLibraryInfo* info = nullptr;
  visnav::PluginCommandInfo pathseg;
  fs::path dir;
};

}  // namespace

TEST_F(PluginFixture, DescriptorIsANodesPluginWithThePathsegCommand) {
  EXPECT_EQ(info->kinds, std::vector<visnav::PluginKind>{visnav::PluginKind::nodes});
  EXPECT_EQ(info->library_name, "path_following");
  EXPECT_NE(std::find(info->command_names.begin(), info->command_names.end(), "pathseg"), info->command_names.end());
  ASSERT_NE(pathseg.run, nullptr);
}

TEST_F(PluginFixture, PathsegPrintsTheCommandAndDrawsTheStages) {
  ASSERT_NE(pathseg.run, nullptr);
  pft::SceneSpec spec;
  spec.centre_px = [](double) { return 200.0; };  // path right of centre → negative ω
  const auto scene = pft::make_scene(spec);
  const auto image = (dir / "pathseg_input.png").string();
  const auto stages = (dir / "pathseg_stages.png").string();
  fs::remove(stages);
  ASSERT_TRUE(cv::imwrite(image, scene.bgr));

  ::testing::internal::CaptureStdout();
  const int rc = run({image, "--draw", stages, "--set", "seg_k=300", "--set", "alpha_radps=1.0"});
  std::fflush(stdout);
  const std::string out = ::testing::internal::GetCapturedStdout();
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("status: ok"), std::string::npos) << out;
  EXPECT_NE(out.find("area_share: 0."), std::string::npos) << out;
  EXPECT_NE(out.find("v_mps: 0."), std::string::npos) << out;
  EXPECT_NE(out.find("omega_radps: -0."), std::string::npos) << out;
  const cv::Mat drawn = cv::imread(stages);
  ASSERT_FALSE(drawn.empty());
  EXPECT_EQ(drawn.cols, 5 * scene.bgr.cols);
  EXPECT_EQ(drawn.rows, scene.bgr.rows);
}

TEST_F(PluginFixture, PathsegReportsBadArgumentsAndInputs) {
  ASSERT_NE(pathseg.run, nullptr);
  const auto image = (dir / "pathseg_bad_input.png").string();
  ASSERT_TRUE(cv::imwrite(image, pft::make_scene(pft::SceneSpec{}).bgr));
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(run({}), 2);
  EXPECT_EQ(run({image, "--bogus"}), 2);
  EXPECT_EQ(run({image, "--set", "novalue"}), 2);
  EXPECT_EQ(run({image, "--set", "seg_kk=3"}), 1);
  EXPECT_EQ(run({image, "--set", "median_blur_px=4"}), 1);
  EXPECT_EQ(run({(dir / "does_not_exist.png").string()}), 1);
  EXPECT_EQ(run({image, "--draw", (dir / "no_such_dir" / "x.png").string()}), 1);
  std::fflush(stdout);
  const std::string err = ::testing::internal::GetCapturedStderr();
  (void)::testing::internal::GetCapturedStdout();
  EXPECT_NE(err.find("unknown key 'seg_kk'"), std::string::npos) << err;
  EXPECT_NE(err.find("median_blur_px must be odd"), std::string::npos) << err;
  EXPECT_NE(err.find("does_not_exist.png"), std::string::npos) << err;

  // A grey image file is read as BGR (imread converts), a dark one gives a status, not an error.
  const auto dark = (dir / "pathseg_dark.png").string();
  ASSERT_TRUE(cv::imwrite(dark, cv::Mat(240, 320, CV_8UC1, cv::Scalar(3))));
  ::testing::internal::CaptureStdout();
  EXPECT_EQ(run({dark}), 0);
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("status: dark frame"), std::string::npos) << out;
}

TEST(PathsegCli, VisnavPathsegRunsThroughTheCommandLine) {
  const fs::path dir = fs::path(VISNAV_TEST_BINARY_DIR) / "test_output" / "path_following";
  fs::create_directories(dir);
  pft::SceneSpec spec;
  spec.centre_px = [](double) { return 120.0; };  // path left of centre → positive ω
  const auto image = (dir / "pathseg_cli_input.png").string();
  ASSERT_TRUE(cv::imwrite(image, pft::make_scene(spec).bgr));
  const std::string cmd = std::string(VISNAV_TEST_CLI) + " pathseg '" + image + "' 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
  const int status = pclose(pipe);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("status: ok"), std::string::npos) << out;
  EXPECT_NE(out.find("omega_radps: +0."), std::string::npos) << out;
}
