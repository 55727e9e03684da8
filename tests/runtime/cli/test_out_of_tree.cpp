// The core is closed for modification: an out-of-tree plugin project builds against the
// installed SDK (find_package(visnav)) and is loaded by the installed CLI through config only.
// Three examples: a plain nodes plugin (examples/out_of_tree_plugin), a navigation primitive
// (examples/primitive), which teaches and replays an edge on the simulated robot, and a plugin
// carrying a robot driver and a detector in one descriptor (examples/devices).
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <opencv2/imgproc.hpp>

#include "error_expect.hpp"
#include "visnav/loader.hpp"
#include "visnav/plugin.hpp"
#include "visnav/runtime_host.hpp"

namespace fs = std::filesystem;

namespace {

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Runs a shell command, output appended to `log`; returns the exit status.
int sh(const std::string& command, const fs::path& log) {
  const std::string full = "(" + command + ") >>'" + log.string() + "' 2>&1";
  const int rc = std::system(full.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : 128;
}

}  // namespace

/// A temporary folder with the SDK installed under prefix/ and `example` (a folder of
/// examples/) configured and built against it under build/.
struct OutOfTreeBuild {
  fs::path dir, prefix, build, log;

  explicit OutOfTreeBuild(const std::string& example) {
    std::string pattern = (fs::temp_directory_path() / "visnav_oot_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) return;
    dir = pattern;
    prefix = dir / "prefix";
    build = dir / "build";
    log = dir / "log.txt";
    const std::string cmake = VISNAV_TEST_CMAKE;
    ok = sh(cmake + " --install '" VISNAV_TEST_BINARY_DIR "' --component sdk --prefix '" + prefix.string() + "'", log) == 0 &&
         fs::exists(prefix / "include/visnav/plugin.hpp") && fs::exists(prefix / "bin/visnav") &&
         sh(cmake + " -S '" VISNAV_TEST_SOURCE_DIR "/examples/" + example + "' -B '" + build.string() +
                "' -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH='" + prefix.string() + "'",
            log) == 0 &&
         sh(cmake + " --build '" + build.string() + "'", log) == 0;
  }
  ~OutOfTreeBuild() {
    if (!dir.empty()) fs::remove_all(dir);
  }
  [[nodiscard]] std::string visnav() const { return (prefix / "bin/visnav").string(); }
  bool ok = false;
};

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(OutOfTreePlugin, BuildsAgainstTheInstalledSdkAndLoadsThroughConfig) {
  const OutOfTreeBuild oot("out_of_tree_plugin");
  ASSERT_TRUE(oot.ok) << read_file(oot.log);
  const fs::path& dir = oot.dir;
  const fs::path& build = oot.build;
  const fs::path& log = oot.log;
  ASSERT_TRUE(fs::exists(build / "libvisnav_example_nodes.so")) << read_file(log);
  const std::string visnav = oot.visnav();

  const fs::path out = dir / "plugins.txt";
  ASSERT_EQ(sh("VISNAV_PLUGIN_PATH='" + build.string() + "' '" + visnav + "' plugins >'" + out.string() + "'", log), 0)
      << read_file(log);
  const std::string listed = "nodes  example_nodes 1.0  (ABI " + std::to_string(visnav::kPluginAbiVersion) + ")";
  EXPECT_NE(read_file(out).find(listed), std::string::npos) << read_file(out);

  // The installed CLI lists it when pointed at the folder, and runs a mission with its node,
  // found through the config's plugin_path alone.
  std::ofstream(dir / "setup.yaml") << "robot: {type: fixture}\n"
                                       "camera: {type: fixture}\n"
                                       "plugin_path: ['" VISNAV_TEST_FIXTURE_PLUGIN_DIR "', build]\n"
                                       "nodes: [example_nodes]\n";
  std::ofstream(dir / "turn.xml") << R"(<root BTCPP_format="4"><BehaviorTree ID="Main">
  <ExampleTurn angle_rad="1.57" rate_radps="0.5"/>
</BehaviorTree></root>)";
  const fs::path run_out = dir / "run.txt";
  const int rc = sh("cd '" + dir.string() + "' && '" + visnav + "' run --config setup.yaml --tree turn.xml >'" +
                        run_out.string() + "'",
                    log);
  EXPECT_EQ(rc, 0) << read_file(log) << read_file(run_out);
  EXPECT_NE(read_file(run_out).find("success"), std::string::npos) << read_file(run_out);
}

// examples/primitive: a navigation primitive (teacher + replayer of edge kind "brightness"),
// loaded through config by the installed CLI, teaches a 3 m edge on the simulated robot (the
// scripted operator drives) and replays it through PlanRoute/FollowRoute.
TEST(OutOfTreePlugin, ExamplePrimitiveTeachesAndReplaysAnEdgeOnTheSimulatedRobot) {
  const OutOfTreeBuild oot("primitive");
  ASSERT_TRUE(oot.ok) << read_file(oot.log);
  ASSERT_TRUE(fs::exists(oot.build / "libvisnav_brightness_primitive.so")) << read_file(oot.log);
  const fs::path& dir = oot.dir;
  std::ofstream(dir / "sim.yaml") << "robot: {type: sim, params: {world: straight6m}}\n"
                                     "camera: {type: sim, params: {width_px: 160, height_px: 120, hfov_deg: 60}}\n"
                                     "plugin_path: [build]\n"
                                     "nodes: [brightness_primitive, navigation, sim_operator]\n"
                                     "run: {tick: frame, rate_hz: 10, lockstep: on, reload_poll_s: 0, "
                                     "telemetry_file: telemetry.jsonl}\n";
  std::ofstream(dir / "route.yaml") << "route:\n  name: s\n  world: straight6m\n  start: [0, 0, 0]\n"
                                       "  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [3, 0]}\n";
  std::ofstream(dir / "teach.xml") << R"(<root BTCPP_format="4"><BehaviorTree ID="Teach">
  <Parallel success_count="2" failure_count="1">
    <ScriptedOperator route_file="route.yaml" force_kind="brightness" primitive="{primitive}" done="{teach_done}"/>
    <TeachRoute start_node="start" primitive="{primitive}" done="{teach_done}" primitives="brightness=TeachBrightnessEdge">
      <TeachBrightnessEdge sample_spacing_m="0.2"/>
    </TeachRoute>
  </Parallel>
</BehaviorTree></root>)";
  std::ofstream(dir / "replay.xml") << R"(<root BTCPP_format="4"><BehaviorTree ID="Replay">
  <Sequence>
    <PlanRoute start="start" goal="n1"/>
    <FollowRoute primitives="brightness=ReplayBrightnessEdge"><ReplayBrightnessEdge speed_mps="0.3"/></FollowRoute>
  </Sequence>
</BehaviorTree></root>)";
  const std::string run = "cd '" + dir.string() + "' && '" + oot.visnav() + "' run --config sim.yaml --map ./map --tree ";
  const fs::path out = dir / "run.txt";
  ASSERT_EQ(sh(run + "teach.xml --create >'" + out.string() + "'", oot.log), 0) << read_file(oot.log) << read_file(out);
  const std::string graph = read_file(dir / "map/graph.yaml");
  EXPECT_NE(graph.find("kind: \"brightness\""), std::string::npos) << graph;

  fs::remove(dir / "telemetry.jsonl");
  ASSERT_EQ(sh(run + "replay.xml >'" + out.string() + "'", oot.log), 0) << read_file(oot.log) << read_file(out);
  // The adapter published the primitive's steps: it drove the edge to its end seeing the taught view.
  const std::string telemetry = read_file(dir / "telemetry.jsonl");
  EXPECT_NE(telemetry.find("\"status\":\"driving\""), std::string::npos) << telemetry.substr(0, 2000);
  // Not recognising the taught brightness for 2 m of the 3 m edge would show as "| slowing".
  EXPECT_EQ(telemetry.find("slowing"), std::string::npos) << "the taught brightness was not recognised";
  EXPECT_NE(telemetry.find("\"distance_m\":2.9"), std::string::npos) << telemetry.substr(telemetry.size() > 2000 ? telemetry.size() - 2000 : 0);
}

// examples/devices: one library, two kinds. The loader indexes both; the robot writes its
// command protocol and parses odometry lines (skipping a malformed one); the detector finds
// and describes corners; bad params name the key.
TEST(OutOfTreePlugin, ExampleDevicesPluginCarriesARobotAndADetector) {
  const OutOfTreeBuild oot("devices");
  ASSERT_TRUE(oot.ok) << read_file(oot.log);
  ASSERT_TRUE(fs::exists(oot.build / "libvisnav_line_devices.so")) << read_file(oot.log);
  const fs::path out = oot.dir / "plugins.txt";
  ASSERT_EQ(sh("VISNAV_PLUGIN_PATH='" + oot.build.string() + "' '" + oot.visnav() + "' plugins >'" + out.string() + "'",
               oot.log),
            0)
      << read_file(oot.log);
  EXPECT_NE(read_file(out).find("robot, detector  line_devices 1.0"), std::string::npos) << read_file(out);

  visnav::PluginLoader loader({oot.build.string()});
  ASSERT_TRUE(loader.scan());
  visnav::StderrLogger logger(visnav::LogLevel::error);
  visnav::ManualClock clock;
  visnav::RuntimeHost host(loader, logger, clock);

  const fs::path commands = oot.dir / "commands.txt", odometry = oot.dir / "odometry.txt";
  std::ofstream(commands).flush();
  std::ofstream(odometry) << "ODOM 0.1 0.05 0 0 0.05\nODOM garbage\nODOM 0.2 0.10 0.01 0.02 0.10\n";
  auto node = visnav::parse_yaml_string("{command_path: '" + commands.string() + "', odometry_path: '" +
                                            odometry.string() + "', max_linear_mps: 0.4}",
                                        "robot.yaml");
  ASSERT_TRUE(node.ok()) << node.error().message;
  {
    auto robot = loader.create<visnav::Robot>("line_robot", *node, host);
    ASSERT_TRUE(robot.ok()) << robot.error().message;
    auto odo = (*robot)->latest_odometry();
    ASSERT_TRUE(odo.has_value());
    EXPECT_DOUBLE_EQ(odo->timestamp_s, 0.2);
    EXPECT_DOUBLE_EQ(odo->distance_m, 0.10);
    EXPECT_DOUBLE_EQ(odo->pose.heading_rad, 0.02);
    ASSERT_TRUE((*robot)->send_command({0.9, 0.1}).ok());  // clamped to max_linear_mps
    ASSERT_TRUE((*robot)->stop().ok());
  }
  EXPECT_EQ(read_file(commands), "CMD 0.4000 0.1000\nCMD 0.0000 0.0000\n");

  auto missing = visnav::parse_yaml_string("{command_path: /nonexistent/tty, odometry_path: /nonexistent/tty}", "r.yaml");
  ASSERT_TRUE(missing.ok());
  auto refused = loader.create<visnav::Robot>("line_robot", *missing, host);
  EXPECT_TRUE(fails_with(refused, ErrorCode::io, At{"/nonexistent/tty"}));

  auto detector_node = visnav::parse_yaml_string("{threshold: 20, max_keypoints: 50}", "detector.yaml");
  ASSERT_TRUE(detector_node.ok());
  auto detector = loader.create<visnav::Detector>("fast_orb", *detector_node, host);
  ASSERT_TRUE(detector.ok()) << detector.error().message;
  cv::Mat image(240, 320, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);  // textured: FAST finds hundreds of corners
  visnav::Features features;
  ASSERT_TRUE((*detector)->detect(image, features).ok());
  EXPECT_GT(features.keypoints.size(), 20u);  // ORB drops the ones too near the border
  EXPECT_LE(features.keypoints.size(), 50u);
  EXPECT_EQ(features.descriptors.rows, static_cast<int>(features.keypoints.size()));
  EXPECT_FALSE((*detector)->detect(cv::Mat(), features).ok());

  auto bad = visnav::parse_yaml_string("{threshold: 0}", "detector.yaml");
  ASSERT_TRUE(bad.ok());
  auto rejected = loader.create<visnav::Detector>("fast_orb", *bad, host);
  EXPECT_TRUE(fails_with(rejected, ErrorCode::out_of_range, At{"detector.yaml", 1, "threshold"}));
}
