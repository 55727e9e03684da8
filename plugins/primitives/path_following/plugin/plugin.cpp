// libvisnav_path_following.so — the segmentation-based path-following primitive (nodes plugin).
//
// Provides the behaviour-tree nodes FollowPathEdge and TeachPathEdge (nodes.hpp) and the
// `visnav pathseg` command.
#include "cmd_pathseg.hpp"
#include "nodes.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::path_following::register_path_nodes(registry, host);
}

const visnav::CommandEntry kCommands[] = {
    {"pathseg", "segment the path in one image and draw the stages (seed 000 Fig. 2)",
     &visnav::guarded_command<&visnav::path_following::run_pathseg>},
};

}  // namespace

namespace {
const visnav::PayloadCheckEntry kPayloadChecks[] = {
    {"path_following", &visnav::path_following::check_path_payload},
};
}  // namespace

VISNAV_PLUGIN({.name = "path_following",
               .version = "0.1.0",
               .description = "Segmentation-based path following (superpixels + Gaussian path models, seed 000 Sec. 4)",
               .register_nodes = &register_nodes,
               .commands = kCommands,
               .payload_checks = kPayloadChecks})
