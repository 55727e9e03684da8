// libvisnav_ipt_obstacles.so — IPT-based obstacle detection and avoidance (nodes plugin,
// issue 16): the ObstacleAhead and AvoidObstacles nodes (nodes.hpp) and `visnav ipt-roc`.
#include <exception>
#include <string>

#include "cmd_ipt_roc.hpp"
#include "nodes.hpp"
#include "visnav/plugin.hpp"

namespace {

int ipt_roc_entry(int argc, char** argv, visnav::HostServices& host) noexcept {
  try {
    return visnav::ipt::run_ipt_roc(argc, argv, host);
  } catch (const std::exception& e) {
    host.logger().error("ipt-roc", std::string("unexpected exception: ") + e.what());
    return 1;
  } catch (...) {
    host.logger().error("ipt-roc", "unexpected non-standard exception");
    return 1;
  }
}

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::ipt::register_ipt_nodes(registry, host);
}

const visnav::CommandEntry kCommands[] = {
    {"ipt-roc", "IPT obstacle/ground classifier on rendered frames: precision, recall, ROC AUC", &ipt_roc_entry},
};

}  // namespace

VISNAV_PLUGIN(visnav::PluginKind::nodes, "ipt_obstacles", "0.1.0",
              "IPT obstacle detection (Bonin-Font thesis): feature classifier, contact points, polar map",
              nullptr, 0, &register_nodes, kCommands, sizeof(kCommands) / sizeof(kCommands[0]))
