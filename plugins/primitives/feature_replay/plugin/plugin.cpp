// libvisnav_feature_replay.so — the feature-based teach-and-replay primitive (nodes plugin).
//
// Provides the behaviour-tree nodes TeachFeatureEdge and ReplayFeatureEdge (the core
// visnav/feature_replay/*.hpp as a teacher and a replayer, see nodes.hpp) and the
// `visnav align` and `visnav train-descriptor` commands.
#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <span>
#include <string>

#include "cmd_align.hpp"
#include "cmd_train_descriptor.hpp"
#include "nodes.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return visnav::feature_replay::register_feature_nodes(registry, host);
}


/// The body states the length the edge was taught with; the graph's length_m decides when the
/// replay ends. A mismatch means one of them was edited (issue 17: a body saying 500 m under a
/// 6.3 m graph entry drove 500 m), so the map is refused. 5 cm + 1 % absorbs the graph's decimal
/// formatting and a local-map body ending at the farthest recorded distance after a small reverse.
visnav::Status check_length(double body_length_m, const visnav::EdgeRecord& edge) {
  const double tolerance_m = 0.05 + 0.01 * std::max(std::fabs(body_length_m), std::fabs(edge.length_m));
  if (!std::isfinite(body_length_m) || std::fabs(body_length_m - edge.length_m) > tolerance_m)
    return visnav::fail("body does not match the graph: body length " + std::to_string(body_length_m) +
                        " m, graph length_m " + std::to_string(edge.length_m) + " m");
  return visnav::ok();
}

template <typename Body>
visnav::Status check_body(std::span<const std::uint8_t> body, const visnav::EdgeRecord& edge) noexcept {
  try {
    auto parsed = Body::deserialize(body);
    if (!parsed) return std::move(parsed).error();
    if (auto st = parsed->validate(); !st) return st;
    return check_length(parsed->length_m, edge);
  } catch (const std::exception& e) {
    return visnav::fail(std::string("payload reader threw: ") + e.what());
  } catch (...) {
    return visnav::fail("payload reader threw a non-standard exception");
  }
}

const visnav::PayloadCheckEntry kPayloadChecks[] = {
    {visnav::feature_replay::kSegmentKind, &check_body<visnav::feature_replay::SegmentMap>},
    {visnav::feature_replay::kLocalMapsKind, &check_body<visnav::feature_replay::LocalMapPath>},
};

const visnav::CommandEntry kCommands[] = {
    {"align", "horizontal image offset of two images (or a list of pairs) by histogram voting",
     &visnav::guarded_command<&visnav::feature_replay::run_align>},
    {"train-descriptor", "evolve GRIEF comparison pairs on aligned image pairs (detector type grief)",
     &visnav::guarded_command<&visnav::feature_replay::run_train_descriptor>},
};

}  // namespace

VISNAV_PLUGIN({.name = "feature_replay",
               .version = "0.1.0",
               .description = "Feature-based teach and replay: histogram-voting heading, segment landmarks (seed "
                              "000) and local maps + recorded commands (seed 002)",
               .register_nodes = &register_nodes,
               .commands = kCommands,
               .payload_checks = kPayloadChecks})
