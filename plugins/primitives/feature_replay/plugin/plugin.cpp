// libvisnav_feature_replay.so — the feature-based teach-and-replay primitive (nodes plugin).
//
// Provides the behaviour-tree nodes TeachFeatureEdge and ReplayFeatureEdge (issue 4, item 5;
// thin adapters over the core visnav/feature_replay/*.hpp, see nodes.hpp) and the
// `visnav align` command.
#include <exception>
#include <memory>
#include <string>

#include "cmd_align.hpp"
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
