// The core is closed for modification: an out-of-tree plugin project builds against the
// installed SDK (find_package(visnav)) and is loaded by the installed CLI through config only.
// Two examples: a plain nodes plugin (examples/out_of_tree_plugin) and a navigation primitive
// (examples/primitive), which teaches and replays an edge on the simulated robot.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "visnav/plugin.hpp"

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
