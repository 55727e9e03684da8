// libvisnav_ipt_obstacles.so — IPT-based obstacle detection and avoidance (nodes plugin,
// issue 16): ObstacleAhead, AvoidObstacles, ReplayAvoiding and ReplayPathAvoiding (nodes.hpp).
// It does not link the simulator: the evaluation commands are in tools/ipt_eval.
#include "nodes.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::ipt::register_ipt_nodes(registry, host);
}

}  // namespace

VISNAV_PLUGIN({.name = "ipt_obstacles",
               .version = "0.1.0",
               .description = "IPT obstacle detection (Bonin-Font thesis): feature classifier, contact points, "
                              "polar map",
               .register_nodes = &register_nodes})
