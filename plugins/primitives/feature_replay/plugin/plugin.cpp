// libvisnav_feature_replay.so — the feature-based teach-and-replay primitive (nodes plugin).
//
// Provides the behaviour-tree nodes TeachFeatureEdge and ReplayFeatureEdge (the core
// visnav/feature_replay/*.hpp as a teacher and a replayer, see nodes.hpp) and the
// `visnav align`, `visnav train-descriptor` and `visnav map-experiences` commands.
#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <span>
#include <string>

#include "cmd_align.hpp"
#include "cmd_experiences.hpp"
#include "cmd_train_descriptor.hpp"
#include "nodes.hpp"
#include "payload_check.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::feature_replay::register_feature_nodes(registry, host);
}


const visnav::PayloadCheckEntry kPayloadChecks[] = {
    {visnav::feature_replay::kSegmentKind, &visnav::feature_replay::check_body<visnav::feature_replay::SegmentMap>},
    {visnav::feature_replay::kLocalMapsKind, &visnav::feature_replay::check_body<visnav::feature_replay::LocalMapPath>},
};

const visnav::CommandEntry kCommands[] = {
    {"align", "horizontal image offset of two images (or a list of pairs) by histogram voting",
     &visnav::guarded_command<&visnav::feature_replay::run_align>},
    {"train-descriptor", "evolve GRIEF comparison pairs on aligned image pairs (detector type grief)",
     &visnav::guarded_command<&visnav::feature_replay::run_train_descriptor>},
    {"map-experiences", "list and check the appearance experiences of a map's feature edges (= visnav map experiences)",
     &visnav::guarded_command<&visnav::feature_replay::run_map_experiences>},
};

}  // namespace

VISNAV_PLUGIN({.name = "feature_replay",
               .version = "0.1.0",
               .description = "Feature-based teach and replay: histogram-voting heading, segment landmarks (seed "
                              "000) and local maps + recorded commands (seed 002)",
               .register_nodes = &register_nodes,
               .commands = kCommands,
               .payload_checks = kPayloadChecks})
