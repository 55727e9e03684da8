// libvisnav_feature_replay.so — the feature-based teach-and-replay primitive (nodes plugin).
//
// Provides the `visnav align` command. The behaviour-tree nodes TeachFeatureEdge and
// ReplayFeatureEdge (issue 4, item 5) are thin adapters over the core
// (visnav/feature_replay/*.hpp) and are registered in register_nodes() in a later step; until
// then the registrar adds no node types.
#include <exception>
#include <string>

#include "cmd_align.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& /*registry*/, visnav::HostServices& /*host*/) {
  return visnav::ok();
}

int align_entry(int argc, char** argv, visnav::HostServices& host) noexcept {
  try {
    return visnav::feature_replay::run_align(argc, argv, host);
  } catch (const std::exception& e) {
    host.logger().error("align", std::string("unexpected exception: ") + e.what());
    return 1;
  } catch (...) {
    host.logger().error("align", "unexpected non-standard exception");
    return 1;
  }
}

const visnav::CommandEntry kCommands[] = {
    {"align", "horizontal image offset of two images (or a list of pairs) by histogram voting", &align_entry},
};

}  // namespace

VISNAV_PLUGIN(visnav::PluginKind::nodes, "feature_replay", "0.1.0",
              "Feature-based teach and replay: histogram-voting heading, segment landmarks (seed 000) and "
              "local maps + recorded commands (seed 002)",
              nullptr, 0, &register_nodes, kCommands, 1)
