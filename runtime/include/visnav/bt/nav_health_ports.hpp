// visnav SDK — the behaviour-tree ports of the lost policy (visnav/nav_health.hpp), shared by
// every replaying primitive so that they are declared once and read alike.
//
// Ports (docs/navigation.md, "Lost detection"):
//   min_frame_confidence   window-mean confidence at which the robot sees the route
//   slow_after_m           blind distance before slowing down
//   max_blind_m            blind distance before stopping with FAILURE "lost: ..."
//   max_frozen_m           travel with identical frames before FAILURE "camera frozen: ..."
//   max_saturated_m        travel with a saturated correction before FAILURE
//   max_heading_deviation_deg  odometry vs taught heading; 0 = off
//   confident_at_m         inout, default {nav_confident_at_m}: carried between edges
//   image_changed_at_m     inout, default {nav_image_changed_at_m}: carried between edges
// Thread-safety: tick thread only.
#pragma once

#include <optional>

#include "visnav/bt/node.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/nav_health.hpp"

namespace visnav::bt {

/// Appends the lost-policy ports to `ports`.
void append_lost_policy_ports(PortsList& ports);

/// Reads and validates the lost policy from a node's ports (error names the port).
[[nodiscard]] Result<LostPolicy> read_lost_policy(const TreeNode& node);

/// Starts `monitor` for an edge from the node's carried inout ports (unset ones count from here).
void begin_nav_health(NavHealthMonitor& monitor, const TreeNode& node, double odom_distance_m,
                      double odom_heading_rad, std::optional<TaughtHeading> taught);

/// Writes the monitor's carried distances to the node's inout ports (errors ignored: the ports
/// may be bound to literals by a tree that does not carry them).
void store_nav_health(const NavHealthMonitor& monitor, TreeNode& node);

}  // namespace visnav::bt
