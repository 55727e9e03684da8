// The edge-progress entries: the blackboard entries through which FollowRoute, the replay
// primitives' adapter (ReplayEdgeNode) and decorators around a replay (ReplayAvoiding) hand one
// edge's progress to each other (and a route-teaching node its edge's nodes to the teach
// primitives). Each is a port's default remapping on every side, so a tree
// needs none of them; a tree that remaps one must remap it on every side.
//
// One name per entry here, and every port that exchanges edge progress takes its default from
// this header: a misspelt literal on one side would silently break the hand-over (the reader
// sees "unset" and falls back). tests/integration/validate checks that every registered port
// whose default is an {edge_*} or {nav_*} entry names one of these.
//
// Units: distances along an edge are taught metres; the nav_* odometer readings are odometric
// metres. Thread-safety: constants.
#pragma once

#include <array>
#include <string_view>

namespace visnav::edge_progress {

/// The edge being traversed (FollowRoute writes, children read).
inline constexpr const char* edge = "{edge}";
/// Distance of the edge already covered when a replay starts, taught m (FollowRoute writes the
/// overshoot carry; ReplayAvoiding rewrites it when it restarts its child mid-edge).
inline constexpr const char* carried_m = "{edge_carried_m}";
/// Odometric metres per taught metre for the edge (FollowRoute's estimate; unset counts as 1).
inline constexpr const char* distance_scale = "{edge_distance_scale}";
/// The replay's visual along-track correction so far, taught m (written every frame).
inline constexpr const char* shift_m = "{edge_shift_m}";
/// When the edge ends: how much earlier than its taught length the replay ended it, odometric m.
inline constexpr const char* end_shift_m = "{edge_end_shift_m}";
/// When the edge ends after a detour: odometric metres that were not progress along the edge.
inline constexpr const char* extra_travel_m = "{edge_extra_travel_m}";
/// The reason of the replay's last FAILURE (text for people; nothing keys on it).
inline constexpr const char* failure = "{edge_failure}";
/// The kind of the replay's last FAILURE (visnav::replay_failure codes, primitive.hpp).
inline constexpr const char* failure_code = "{edge_failure_code}";
/// Odometer reading at which the route was last seen confidently (lost detection), odometric m.
inline constexpr const char* confident_at_m = "{nav_confident_at_m}";
/// Odometer reading at which the image last changed (frozen-camera detection), odometric m.
inline constexpr const char* image_changed_at_m = "{nav_image_changed_at_m}";

/// Teaching: the start node of the edge being taught (a route-teaching node writes it, the
/// teach primitives read it).
inline constexpr const char* edge_from = "{edge_from}";
/// Teaching: the end node, set when the edge being taught is finished.
inline constexpr const char* edge_to = "{edge_to}";

/// Every entry above, for checks over all registered ports.
inline constexpr std::array<std::string_view, 12> all = {
    edge, carried_m, distance_scale, shift_m, end_shift_m, extra_travel_m, failure, failure_code,
    confident_at_m, image_changed_at_m, edge_from, edge_to};

}  // namespace visnav::edge_progress
