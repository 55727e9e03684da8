// Behaviour-tree nodes of the path-following primitive (protocol: docs/navigation.md).
//  * FollowPathEdge — replays an edge of kind `path_following`: follows the visible path with
//    control law (1) until the odometric distance reaches the edge's length; FAILURE "path lost"
//    when the path is not seen for longer than grace_s. The edge's appearance summary gates the
//    re-learned reference models (taught_gate_distance, see path_follower.hpp).
//  * TeachPathEdge — teaches such an edge: records only its odometric length and the path's
//    appearance summary (AppearanceSummary over the teach frames' reference colour models),
//    seed 000 Sec. 2 advantage 4.
// Thread-safety: tick thread only.
#pragma once

#include <cstdint>
#include <span>

#include "visnav/bt/registry.hpp"
#include "visnav/host.hpp"
#include "visnav/map.hpp"

namespace visnav::path_following {

/// Registers FollowPathEdge and TeachPathEdge.
Status register_path_nodes(bt::NodeRegistry& registry, HostServices& host);

/// Decodes a path_following payload body (the appearance summary) as FollowPathEdge does; the
/// plugin's PayloadCheckEntry (map validate, route checks before moving). Never throws.
Status check_path_payload(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept;

}  // namespace visnav::path_following
