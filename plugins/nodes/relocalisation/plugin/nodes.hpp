// Behaviour-tree nodes of the relocalisation plugin (docs/relocalisation.md):
//  * Relocalise — with the robot stopped (optionally turning in place to look around), answers
//    where on the map it is: {reloc_edge}, {reloc_distance_m}, {reloc_heading_offset_rad},
//    {reloc_turn_rad}, {reloc_confidence}; or fails with {reloc_status} ambiguous / not_on_map /
//    camera_blocked and {reloc_reason}. Never from a single frame.
//  * BuildPlaceIndex — builds (or rebuilds) the map's place index; the teach trees end with it.
//
// Thread-safety: tick thread only. The HostServices reference outlives the tree.
#pragma once

#include "visnav/bt/registry.hpp"
#include "visnav/host.hpp"
#include "visnav/result.hpp"

namespace visnav::reloc {

Status register_reloc_nodes(bt::NodeRegistry& registry, HostServices& host);

}  // namespace visnav::reloc
