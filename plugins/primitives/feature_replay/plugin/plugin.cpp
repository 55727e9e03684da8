// libvisnav_feature_replay.so — the feature-based teach-and-replay primitive (nodes plugin).
//
// Provides the behaviour-tree nodes TeachFeatureEdge and ReplayFeatureEdge (issue 4, item 5;
// thin adapters over the core visnav/feature_replay/*.hpp, see nodes.hpp) and the
// `visnav align` and `visnav train-descriptor` commands.
#include <exception>
#include <memory>
#include <string>

#include "cmd_align.hpp"
#include "cmd_train_descriptor.hpp"
#include "nodes.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  using visnav::feature_replay::ReplayFeatureEdge;
  using visnav::feature_replay::TeachFeatureEdge;
  VISNAV_TRY(registry.register_node<TeachFeatureEdge>(
      "TeachFeatureEdge",
      "Records a feature edge while the operator drives: style segment (feature_segment, seed 000) or localmaps "
      "(feature_localmaps, seed 002)",
      [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
        return std::make_unique<TeachFeatureEdge>(name, config, host);
      }));
  VISNAV_TRY(registry.register_node<ReplayFeatureEdge>(
      "ReplayFeatureEdge",
      "Traverses a feature_segment or feature_localmaps edge, steering by histogram voting of feature offsets",
      [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
        return std::make_unique<ReplayFeatureEdge>(name, config, host);
      }));
  return visnav::ok();
}

template <int (*Run)(int, char**, visnav::HostServices&)>
int command_entry(const char* name, int argc, char** argv, visnav::HostServices& host) noexcept {
  try {
    return Run(argc, argv, host);
  } catch (const std::exception& e) {
    host.logger().error(name, std::string("unexpected exception: ") + e.what());
    return 1;
  } catch (...) {
    host.logger().error(name, "unexpected non-standard exception");
    return 1;
  }
}

int align_entry(int argc, char** argv, visnav::HostServices& host) noexcept {
  return command_entry<&visnav::feature_replay::run_align>("align", argc, argv, host);
}
int train_entry(int argc, char** argv, visnav::HostServices& host) noexcept {
  return command_entry<&visnav::feature_replay::run_train_descriptor>("train-descriptor", argc, argv, host);
}

const visnav::CommandEntry kCommands[] = {
    {"align", "horizontal image offset of two images (or a list of pairs) by histogram voting", &align_entry},
    {"train-descriptor", "evolve GRIEF comparison pairs on aligned image pairs (detector type grief)", &train_entry},
};

}  // namespace

VISNAV_PLUGIN(visnav::PluginKind::nodes, "feature_replay", "0.1.0",
              "Feature-based teach and replay: histogram-voting heading, segment landmarks (seed 000) and "
              "local maps + recorded commands (seed 002)",
              nullptr, 0, &register_nodes, kCommands, sizeof(kCommands) / sizeof(kCommands[0]))
