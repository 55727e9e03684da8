// The AvoidObstacles node through the real `visnav run` (real loader, ipt_obstacles .so, sim
// robot and camera) in the obstacle course: past two crates to a goal 7 m ahead; and a goal
// behind a wall, which must end in FAILURE with the reason logged, not run forever.
#include <array>
#include <cstdio>
#include <string>

#include <sys/wait.h>

#include <gtest/gtest.h>

namespace {

struct CliRun {
  int status = -1;
  std::string output;
};

CliRun run_cli(const std::string& args) {
  const std::string cmd = std::string(VISNAV_TEST_CLI) + " run --plugin-path " + VISNAV_TEST_PLUGIN_DIR + " --config " +
                          VISNAV_TEST_SOURCE_DIR + "/config/sim_obstacles.yaml --tree " + VISNAV_TEST_SOURCE_DIR +
                          "/trees/avoid_obstacles.xml " + args + " 2>&1";
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

}  // namespace
