// Plugin loader: the real fixture .so files through the real loader, every error case.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>

#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"
#include "error_expect.hpp"

namespace fs = std::filesystem;
using visnav::PluginKind;
using visnav::PluginLoader;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

const std::string kFixtures = VISNAV_TEST_FIXTURE_PLUGIN_DIR;
const std::string kBroken = std::string(VISNAV_TEST_FIXTURE_PLUGIN_DIR) + "/broken";

std::string lib(const std::string& dir, const std::string& name) { return dir + "/libvisnav_" + name + ".so"; }

fs::path make_temp_dir() {
  std::string pattern = (fs::temp_directory_path() / "visnav_loader_XXXXXX").string();
  const char* made = mkdtemp(pattern.data());
  EXPECT_NE(made, nullptr);
  return fs::path(pattern);
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// A host for factories (its own, empty loader; the fixtures only use logger/clock/robot).
struct TestHost {
  PluginLoader host_loader{std::vector<std::string>{}};
  visnav::StderrLogger logger{visnav::LogLevel::warn};
  visnav::ManualClock clock;
  visnav::RuntimeHost host{host_loader, logger, clock};
};

}  // namespace

TEST(Loader, DefaultSearchPathIsBuildInstallThenEnvironment) {
  ::setenv("VISNAV_PLUGIN_PATH", "/opt/a::/opt/b", 1);
  const auto dirs = PluginLoader::default_search_path();
  ::unsetenv("VISNAV_PLUGIN_PATH");
  ASSERT_EQ(dirs.size(), 4u);
  EXPECT_EQ(dirs[0], VISNAV_TEST_PLUGIN_DIR);
  EXPECT_TRUE(contains(dirs[1], "visnav/plugins"));
  EXPECT_EQ(dirs[2], "/opt/a");  // empty entries are skipped
  EXPECT_EQ(dirs[3], "/opt/b");
  EXPECT_EQ(PluginLoader::default_search_path().size(), 2u);
}

TEST(Loader, ScansGoodFixturesAndIndexesTypes) {
  PluginLoader loader({kFixtures});
  auto n = loader.scan();
  ASSERT_TRUE(n) << n.error().message;
  EXPECT_GE(*n, 4u);  // robot, camera, detector, nodes (other test areas may add fixtures here)
  EXPECT_TRUE(loader.problems().empty()) << loader.problems().front().message;  // broken/ is not scanned
  auto robot = loader.find_type(PluginKind::robot, "fixture");
  ASSERT_TRUE(robot) << robot.error().message;
  EXPECT_EQ(fs::path(robot->library_path).filename(), "libvisnav_fixture_robot.so");
  EXPECT_TRUE(loader.find_type(PluginKind::detector, "grid_l2"));
  // Same type name, different kind: the camera "fixture" is a separate entry.
  auto camera = loader.find_type(PluginKind::camera, "fixture");
  ASSERT_TRUE(camera);
  EXPECT_NE(camera->library_path, robot->library_path);
  for (const auto* l : loader.libraries()) EXPECT_EQ(l->abi_version, visnav::kPluginAbiVersion);
}

TEST(Loader, ScanningTwiceLoadsNothingNew) {
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  const auto libs = loader.libraries().size();
  const auto problems = loader.problems().size();
  auto again = loader.scan();
  ASSERT_TRUE(again);
  EXPECT_EQ(*again, 0u);
  EXPECT_EQ(loader.libraries().size(), libs);
  EXPECT_EQ(loader.problems().size(), problems);
}

TEST(Loader, CreatesWorkingRobotThroughFactory) {
  TestHost h;
  PluginLoader loader({kFixtures});
  ASSERT_TRUE(loader.scan());
  auto robot = loader.create<visnav::Robot>("fixture", visnav::ConfigNode{}, h.host);
  ASSERT_TRUE(robot) << robot.error().message;
  ASSERT_NE((*robot)->simulation(), nullptr);
  ASSERT_TRUE((*robot)->send_command({0.5, 0.0}));
  ASSERT_TRUE((*robot)->simulation()->step(2.0));
  auto odo = (*robot)->latest_odometry();
  ASSERT_TRUE(odo);
  EXPECT_NEAR(odo->distance_m, 1.0, 1e-9);
  EXPECT_NEAR(odo->timestamp_s, 2.0, 1e-9);
}

TEST(Loader, FactoryParamErrorsCarryTypeLibraryAndLocation) {
  TestHost h;
  PluginLoader loader({kFixtures});
  ASSERT_TRUE(loader.scan());
  visnav::ConfigNode params = visnav::ConfigNode::make_map({"robot.yaml", 3});
  params.set("max_speed_mps", visnav::ConfigNode::make_scalar("99", {"robot.yaml", 4}));
  auto robot = loader.create<visnav::Robot>("fixture", params, h.host);
  ASSERT_FALSE(robot);
  const auto& m = robot.error().message;
  EXPECT_TRUE(contains(m, "robot 'fixture' (libvisnav_fixture_robot.so)")) << m;
  EXPECT_TRUE(contains(m, "robot.yaml:4: key 'max_speed_mps': value 99 is out of range [0, 10]")) << m;
}

TEST(Loader, LibraryNotFoundListsEveryPathTried) {
  PluginLoader loader({"/nonexistent/one", kFixtures});
  auto r = loader.load_library("robot_nowhere");
  ASSERT_FALSE(r);
  const auto& m = r.error().message;
  EXPECT_TRUE(contains(m, "'robot_nowhere' not found")) << m;
  EXPECT_TRUE(contains(m, "/nonexistent/one/libvisnav_robot_nowhere.so")) << m;
  EXPECT_TRUE(contains(m, kFixtures + "/libvisnav_robot_nowhere.so")) << m;
}

TEST(Loader, UnknownTypeListsSearchPathAndKnownTypes) {
  PluginLoader loader({kFixtures, "/nonexistent/two"});
  ASSERT_TRUE(loader.scan());
  auto r = loader.find_type(PluginKind::camera, "stereo");
  EXPECT_TRUE(fails_with(r, ErrorCode::not_found));
  const auto& m = r.error().message;  // what is known and where it looked
  EXPECT_TRUE(contains(m, "no camera plugin provides type 'stereo'")) << m;
  EXPECT_TRUE(contains(m, "fixture (libvisnav_fixture_camera.so)")) << m;
  EXPECT_TRUE(contains(m, kFixtures)) << m;
  EXPECT_TRUE(contains(m, "/nonexistent/two (missing)")) << m;
}

TEST(Loader, MissingEntrySymbolIsRefused) {
  PluginLoader loader({});
  auto r = loader.load_library(lib(kBroken, "fixture_no_entry"));
  ASSERT_FALSE(r);
  EXPECT_TRUE(fails_with(r, ErrorCode::plugin, At{"libvisnav_fixture_no_entry.so"}));
  EXPECT_TRUE(contains(r.error().message, "entry symbol 'visnav_plugin_entry' not found")) << r.error().message;  // the reason
  EXPECT_TRUE(loader.libraries().empty());
}

TEST(Loader, AbiMismatchNamesLibraryAndBothVersions) {
  PluginLoader loader({});
  auto r = loader.load_library(lib(kBroken, "fixture_wrong_abi"));
  ASSERT_FALSE(r);
  EXPECT_TRUE(fails_with(r, ErrorCode::plugin, At{"libvisnav_fixture_wrong_abi.so"}));
  const auto& m = r.error().message;  // both versions are told
  EXPECT_TRUE(contains(m, "plugin ABI version " + std::to_string(visnav::kPluginAbiVersion + 998))) << m;
  EXPECT_TRUE(contains(m, "runtime's ABI version " + std::to_string(visnav::kPluginAbiVersion))) << m;
}

TEST(Loader, DlopenFailureReportsDlerror) {
  const fs::path dir = make_temp_dir();
  { std::ofstream(dir / "libvisnav_garbage.so") << "this is not an ELF file"; }
  PluginLoader loader({dir.string()});
  ASSERT_TRUE(loader.scan());
  ASSERT_EQ(loader.problems().size(), 1u);
  EXPECT_TRUE(contains(loader.problems()[0].message, "dlopen failed")) << loader.problems()[0].message;
  EXPECT_TRUE(contains(loader.problems()[0].message, "libvisnav_garbage.so")) << loader.problems()[0].message;
  fs::remove_all(dir);
}

TEST(Loader, DuplicateTypeNamesBothLibrariesAndPinningResolvesIt) {
  TestHost h;
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  bool reported = false;
  for (const auto& p : loader.problems())
    reported |= contains(p.message, "duplicate camera type 'dup_camera'") && contains(p.message, "fixture_dup_a") &&
                contains(p.message, "fixture_dup_b");
  EXPECT_TRUE(reported);

  auto ambiguous = loader.create<visnav::Camera>("dup_camera", visnav::ConfigNode{}, h.host);
  ASSERT_FALSE(ambiguous);
  const auto& m = ambiguous.error().message;
  EXPECT_TRUE(contains(m, "libvisnav_fixture_dup_a.so") && contains(m, "libvisnav_fixture_dup_b.so")) << m;
  EXPECT_TRUE(contains(m, "plugin: <library>")) << m;

  auto pinned = loader.create<visnav::Camera>("dup_camera", visnav::ConfigNode{}, h.host, "fixture_dup_b");
  ASSERT_TRUE(pinned) << pinned.error().message;
  auto frame = (*pinned)->grab(0.0);
  ASSERT_TRUE(frame && frame->has_value());
  EXPECT_EQ((**frame).image.at<std::uint8_t>(0, 0), 'b');
}

TEST(Loader, FactoryThrowingPastTheBoundaryIsCaughtByTheHost) {
  TestHost h;
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  auto r = loader.create<visnav::Camera>("raw_throw", visnav::ConfigNode{}, h.host);
  EXPECT_TRUE(fails_with(r, ErrorCode::plugin));
  EXPECT_TRUE(contains(r.error().message, "camera 'raw_throw' (libvisnav_fixture_throwing.so)")) << r.error().message;
  // Content: the exception's text crosses the plugin boundary as an error message.
  EXPECT_TRUE(contains(r.error().message, "factory threw an exception: raw factory exploded")) << r.error().message;
}

TEST(Loader, FactoryThrowingInsidePluginFactoryBecomesError) {
  TestHost h;
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  auto r = loader.create<visnav::Camera>("wrapped_throw", visnav::ConfigNode{}, h.host);
  ASSERT_FALSE(r);
  EXPECT_TRUE(contains(r.error().message, "wrapped factory exploded")) << r.error().message;
}

TEST(Loader, FactoryErrorIsPassedOnWithContext) {
  TestHost h;
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  auto r = loader.create<visnav::Camera>("fails", visnav::ConfigNode{}, h.host);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().message, "camera 'fails' (libvisnav_fixture_throwing.so): device /dev/fixture0 is not there");
}

TEST(Loader, PinnedLibraryOfWrongKindIsRefused) {
  TestHost h;
  PluginLoader loader({kFixtures});
  auto r = loader.create<visnav::Robot>("fixture", visnav::ConfigNode{}, h.host, "fixture_camera");
  EXPECT_TRUE(fails_with(r, ErrorCode::not_found));
  EXPECT_TRUE(contains(r.error().message, "(it provides: camera)")) << r.error().message;  // what it does provide
}

TEST(Loader, PinnedLibraryIsLoadedOnDemandByName) {
  TestHost h;
  PluginLoader loader({kFixtures});  // no scan()
  auto r = loader.create<visnav::Detector>("grid_l2", visnav::ConfigNode{}, h.host, "fixture_detector");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ((*r)->norm(), visnav::DescriptorNorm::l2);
  EXPECT_EQ(loader.libraries().size(), 1u);
}

TEST(Loader, FirstFileOfAGivenNameWins) {
  const fs::path a = make_temp_dir();
  const fs::path b = make_temp_dir();
  fs::copy_file(lib(kFixtures, "fixture_camera"), a / "libvisnav_fixture_camera.so");
  fs::copy_file(lib(kFixtures, "fixture_camera"), b / "libvisnav_fixture_camera.so");
  PluginLoader loader({a.string(), b.string()});
  ASSERT_TRUE(loader.scan());
  ASSERT_EQ(loader.libraries().size(), 1u);
  EXPECT_EQ(fs::path(loader.libraries()[0]->path).parent_path(), fs::canonical(a));
  ASSERT_EQ(loader.problems().size(), 1u);
  EXPECT_TRUE(contains(loader.problems()[0].message, "shadowed by")) << loader.problems()[0].message;
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(Loader, ObjectsKeepTheirLibraryLoadedAfterTheLoaderIsGone) {
  TestHost h;
  visnav::PluginPtr<visnav::Detector> detector;
  {
    PluginLoader loader({kFixtures});
    ASSERT_TRUE(loader.scan());
    auto made = loader.create<visnav::Detector>("grid_hamming", visnav::ConfigNode{}, h.host);
    ASSERT_TRUE(made);
    detector = std::move(made).value();
  }
  cv::Mat image(64, 64, CV_8UC1, cv::Scalar(0));
  image(cv::Rect(0, 0, 40, 40)).setTo(255);  // edges inside 16 px cells
  visnav::Features features;
  ASSERT_TRUE(detector->detect(image, features));  // code still mapped
  EXPECT_FALSE(features.keypoints.empty());
  detector.reset();  // destructor runs inside the library, then the library is closed
}

TEST(Loader, ParamDocsComeFromThePlugin) {
  PluginLoader loader({kFixtures});
  ASSERT_TRUE(loader.scan());
  auto docs = loader.param_docs(PluginKind::robot, "fixture");
  ASSERT_TRUE(docs) << docs.error().message;
  bool found = false;
  for (const auto& d : *docs) {
    if (d.name != "max_speed_mps") continue;
    found = true;
    EXPECT_EQ(d.type, "double");
    EXPECT_EQ(d.default_value, "2");
    EXPECT_EQ(d.constraint, "[0, 10]");
  }
  EXPECT_TRUE(found);
}

TEST(Loader, CollectsNodesPluginsAndCommands) {
  PluginLoader loader({kFixtures});
  ASSERT_TRUE(loader.scan());
  auto nodes = loader.nodes_plugins();
  // Other test areas may add nodes fixtures to this folder; this test is about fixture_nodes.
  std::erase_if(nodes, [](const auto& p) { return p.library->library_name != "fixture_nodes"; });
  ASSERT_EQ(nodes.size(), 1u);
  EXPECT_NE(nodes[0].register_nodes, nullptr);
  const auto commands = loader.commands();
  ASSERT_EQ(commands.size(), 1u);
  EXPECT_EQ(commands[0].name, "fixture-hello");
  EXPECT_TRUE(contains(commands[0].library_path, "libvisnav_fixture_nodes.so"));
}

TEST(Loader, UnknownTypeErrorMentionsLibrariesThatFailed) {
  PluginLoader loader({kBroken});
  ASSERT_TRUE(loader.scan());
  auto r = loader.find_type(PluginKind::robot, "sim");
  EXPECT_TRUE(fails_with(r, ErrorCode::not_found));
  EXPECT_TRUE(contains(r.error().message, "libraries not used")) << r.error().message;
  EXPECT_TRUE(contains(r.error().message, "ABI version")) << r.error().message;
}

TEST(Loader, KindNamesRoundTrip) {
  for (auto k : {PluginKind::robot, PluginKind::camera, PluginKind::detector, PluginKind::nodes})
    EXPECT_EQ(visnav::plugin_kind_from_string(visnav::to_string(k)), k);
  EXPECT_FALSE(visnav::plugin_kind_from_string("lidar"));
}
