// feature_replay plugin — the primitive's teacher and replayer (visnav/primitive.hpp), made
// into the behaviour-tree nodes TeachFeatureEdge and ReplayFeatureEdge by the runtime's adapter:
//
//  * TeachFeatureEdge  — records one map edge while the operator drives: style "segment" (map
//    style A, seed 000 Algorithm 1, edge kind `feature_segment`) or "localmaps" (map style B,
//    seed 002 Sec. 2.3, edge kind `feature_localmaps`, with the operator's (v, ω) taken from the
//    odometry twist).
//  * ReplayFeatureEdge — traverses an edge of either kind (seed 000 Algorithm 2 / seed 002
//    Sec. 2.4), with the start-view search (docs/navigation.md, "Finding the start view").
//
// The protocol (ports `{edge}`, `{edge_carried_m}`, ..., lost policy, frame de-duplication,
// telemetry, send failures) is the adapter's; ports and tuned defaults: docs/feature_replay.md,
// section "Behaviour-tree nodes". Headings are odom-frame radians, CCW positive.
// Thread-safety: tick thread only.
#pragma once

#include "visnav/bt/registry.hpp"
#include "visnav/feature_replay/experience.hpp"  // kSegmentKind, kLocalMapsKind
#include "visnav/host.hpp"

namespace visnav::feature_replay {

/// Registers TeachFeatureEdge and ReplayFeatureEdge.
Status register_feature_nodes(bt::NodeRegistry& registry, HostServices& host);

}  // namespace visnav::feature_replay
