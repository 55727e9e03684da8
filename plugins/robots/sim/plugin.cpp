// The `simulator` plugin: robot type `sim`, camera type `sim` (rendering that robot's world) and
// the `visnav sim ...` commands, in one descriptor. The camera finds the run's robot through
// HostServices::robot(). The implementation lives in libvisnav_sim (visnav_sim/*.hpp).
#include <iostream>
#include <string>
#include <vector>

#include "visnav/plugin.hpp"
#include "visnav_sim/camera.hpp"
#include "visnav_sim/commands.hpp"
#include "visnav_sim/robot.hpp"

namespace {

int run_sim(int argc, char** argv, visnav::HostServices& host) {
  (void)host;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
  return visnav::sim::sim_main(args, std::cout, std::cerr);
}

const visnav::TypeEntry kTypes[] = {
    visnav::make_type<visnav::sim::SimRobot>(
        "sim", "simulated diff-drive/car-like/tracked robot with odometry errors and ground truth"),
    visnav::make_type<visnav::sim::SimCamera>(
        "sim", "pinhole camera rendering the sim robot's textured world (appearance changes, faults)"),
};
const visnav::CommandEntry kCommands[] = {
    {"sim", "simulator tools: snapshot, topview, drive (route script), teleop (keyboard)",
     &visnav::guarded_command<&run_sim>}};

}  // namespace

VISNAV_PLUGIN({.name = "simulator",
               .version = "0.2.0",
               .description = "textured-world simulator: robot and camera of type sim, `visnav sim` tools",
               .types = kTypes,
               .commands = kCommands})
