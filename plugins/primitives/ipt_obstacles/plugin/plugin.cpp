// libvisnav_ipt_obstacles.so — IPT-based obstacle detection and avoidance (nodes plugin,
// issue 16): the ObstacleAhead and AvoidObstacles nodes (nodes.hpp), `visnav ipt-roc`,
// `visnav ipt-ekf` and `visnav calibrate-ipt`.
#include <exception>
#include <string>

#include "cmd_calibrate_ipt.hpp"
#include "cmd_ipt_ekf.hpp"
#include "cmd_ipt_roc.hpp"
#include "nodes.hpp"
#include "visnav/plugin.hpp"

namespace {


visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::ipt::register_ipt_nodes(registry, host);
}

const visnav::CommandEntry kCommands[] = {
    {"ipt-roc", "IPT obstacle/ground classifier on rendered frames: precision, recall, ROC AUC",
     &visnav::guarded_command<&visnav::ipt::run_ipt_roc>},
    {"ipt-ekf", "the robocentric EKF on the IPT pipeline's ground features along a rendered run: drift and NEES",
     &visnav::guarded_command<&visnav::ipt::run_ipt_ekf>},
    {"calibrate-ipt", "camera height and pitch for the IPT from flat-ground frames (NLopt), in the simulator",
     &visnav::guarded_command<&visnav::ipt::run_calibrate_ipt>},
};

}  // namespace

VISNAV_PLUGIN({.name = "ipt_obstacles",
               .version = "0.1.0",
               .description = "IPT obstacle detection (Bonin-Font thesis): feature classifier, contact points, "
                              "polar map",
               .register_nodes = &register_nodes,
               .commands = kCommands})
