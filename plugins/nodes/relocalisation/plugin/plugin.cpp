// libvisnav_relocalisation.so — relocalisation onto a taught map (issue 21): the Relocalise and
// BuildPlaceIndex nodes (nodes.hpp) and the `visnav reloc-index` command (cmd_index.hpp).
#include "cmd_index.hpp"
#include "nodes.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::reloc::register_reloc_nodes(registry, host);
}

const visnav::CommandEntry kCommands[] = {
    {"reloc-index", "build, rebuild or check a map's place index (for Relocalise)",
     &visnav::guarded_command<&visnav::reloc::run_reloc_index>},
};

}  // namespace

VISNAV_PLUGIN({.name = "relocalisation",
               .version = "0.1.0",
               .description = "Relocalisation onto a taught map: place index of the feature edges, Relocalise "
                              "(sequence-verified), BuildPlaceIndex, reloc-index",
               .register_nodes = &register_nodes,
               .commands = kCommands})
