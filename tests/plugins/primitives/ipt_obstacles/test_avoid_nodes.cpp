// The IPT nodes through the real `visnav run` (real loader, ipt_obstacles .so, sim robot and
// camera):
//  * AvoidObstacles in the obstacle course: past two crates to a goal 7 m ahead; a goal behind a
//    wall must end in FAILURE with the reason logged, not run forever;
//  * replay with avoidance (trees/replay_route_avoiding.xml): a 12 m feature edge taught on a
//    clear gravel path, replayed with a van parked on it (seed 002's field report): the replay
//    detours around the van, resumes the edge at the along-track distance reached, and succeeds.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace {

struct CliRun {
  int status = -1;
  std::string output;
};

CliRun run_cli(const std::string& args, const std::string& tree = "avoid_obstacles.xml") {
  const std::string cmd = std::string(VISNAV_TEST_CLI) + " run --plugin-path " + VISNAV_TEST_PLUGIN_DIR + " --config " +
                          VISNAV_TEST_SOURCE_DIR + "/config/sim_obstacles.yaml --tree " + VISNAV_TEST_SOURCE_DIR +
                          "/trees/" + tree + " " + args + " 2>&1";
  CliRun r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), static_cast<int>(buf.size()), pipe) != nullptr) r.output += buf.data();
  const int st = pclose(pipe);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

TEST(AvoidObstaclesNode, ReachesAGoalPastTheCrates) {
  const CliRun r = run_cli("--bb goal_ahead_m=7");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("goal_reached"), std::string::npos) << r.output;
}

TEST(AvoidObstaclesNode, AGoalBehindAWallFailsWithAReason) {
  const CliRun r = run_cli("--bb goal_ahead_m=4 --set \"robot.params.start_pose=0;3.6;90\"");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("stopped: "), std::string::npos) << r.output;
}

constexpr const char* kClearPath = R"(world:
  name: van_path
  ground_resolution_m: 0.025
  sky_zenith: [95, 140, 205]
  sky_horizon: [205, 220, 235]
  fog_distance_m: 200
  start: [0, 0, 0]
  textures:
    grass:   {image: "skimage:grass", color: [92, 135, 58], size_m: 1.6}
    gravel:  {image: "skimage:gravel", color: [158, 146, 128], size_m: 1.4}
    brick:   {procedural: bricks, color: [168, 84, 60], color2: [205, 200, 190], size_m: 2.4, cell_m: 0.3, cell_h_m: 0.1, grout_m: 0.012, detail: 0.18, pixels: 1024}
    van:     {procedural: noise, color: [226, 228, 232], color2: [150, 155, 165], size_m: 2.0, feature_m: 0.08, detail: 0.25}
    facade:  {procedural: facade, color: [214, 204, 182], color2: [186, 174, 150], size_m: 8.0, bay_m: 2.0, storey_m: 4.0, window_w_m: 1.1, window_h_m: 1.8, sill_m: 1.0, pixels: 1024}
  default_ground: {texture: grass, class: grass}
  regions:
    - {name: path, texture: gravel, class: path, width_m: 2.2, polyline: [[-10, 0], [40, 0]]}
  walls:
    - {name: building, texture: facade, height_m: 10, closed: true, polyline: [[24, -10], [34, -10], [34, 10], [24, 10]]}
    - {name: wall_north, texture: brick, height_m: 2.0, polyline: [[-10, 6], [20, 6]]}
)";

void write(const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; }

TEST(ReplayAvoiding, TaughtOnAClearPathReplayedPastAParkedVan) {
  const auto dir = std::filesystem::temp_directory_path() / ("visnav_ipt_replay_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  write(dir / "clear.yaml", kClearPath);
  write(dir / "van.yaml", std::string(kClearPath) + "  obstacles:\n    - {name: van, kind: van, at: [6.5, 0.3], texture: van}\n");
  write(dir / "route.yaml", "route:\n  name: line\n  start: [0, 0, 0]\n  waypoints:\n    - {at: [0, 0], kind: feature}\n"
                            "    - {at: [12, 0]}\n");
  const std::string map = (dir / "map").string();
  const CliRun teach = run_cli("--set robot.params.world=" + (dir / "clear.yaml").string() + " --map " + map +
                                   " --create --bb route_file=" + (dir / "route.yaml").string() +
                                   " --bb style=segment --bb force_kind=feature_segment --bb close_loop=false",
                               "teach_feature_edge.xml");
  ASSERT_EQ(teach.status, 0) << teach.output;
  const CliRun replay = run_cli("--set robot.params.world=" + (dir / "van.yaml").string() + " --map " + map +
                                    " --bb start=start --bb goal=n1 --bb detour_m=8",
                                "replay_route_avoiding.xml");
  EXPECT_EQ(replay.status, 0) << replay.output;
  EXPECT_NE(replay.output.find("obstacle ahead at"), std::string::npos) << replay.output;
  EXPECT_NE(replay.output.find("detour done: the edge resumes at"), std::string::npos) << replay.output;
  std::filesystem::remove_all(dir);
}

}  // namespace
