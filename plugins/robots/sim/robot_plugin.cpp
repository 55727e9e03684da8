// The `robot_sim` plugin: robot type `sim` and the `visnav sim ...` commands.
// The implementation lives in libvisnav_sim (visnav_sim/robot.hpp, visnav_sim/commands.hpp).
#include <iostream>
#include <string>
#include <vector>

#include "visnav/plugin.hpp"
#include "visnav_sim/commands.hpp"
#include "visnav_sim/robot.hpp"

namespace {

int run_sim(int argc, char** argv, visnav::HostServices& host) {
  (void)host;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
  return visnav::sim::sim_main(args, std::cout, std::cerr);
}

const visnav::TypeEntry kTypes[] = {visnav::make_type<visnav::sim::SimRobot>(
    "sim", "simulated diff-drive/car-like/tracked robot with odometry errors and ground truth")};
const visnav::CommandEntry kCommands[] = {
    {"sim", "simulator tools: snapshot, topview, drive (route script), teleop (keyboard)", &run_sim}};

}  // namespace

VISNAV_PLUGIN(visnav::PluginKind::robot, "robot_sim", "0.1.0", "simulated robot (textured-world simulator)", kTypes, 1,
              nullptr, kCommands, 1)
