// visnav simulator — process-wide registry of simulated robots.
//
// The `sim` robot registers its RobotCore under its name when created and removes it when
// destroyed; the `sim` camera looks the robot up (by name, or the first registered robot)
// to render from its pose. Both plugin .so files link libvisnav_sim.so, so they share one
// registry. The registry holds weak references: a lookup never keeps a destroyed robot alive
// beyond the returned shared_ptr.
//
// Thread-safety: all functions are thread-safe.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::sim {

class RobotCore;

/// Registers `core` under `name`; fails if a live robot already has that name.
[[nodiscard]] Status register_robot(const std::string& name, const std::shared_ptr<RobotCore>& core);
/// Removes `name` if it refers to `core`.
void unregister_robot(const std::string& name, const RobotCore* core);
/// The robot called `name`; with an empty name the first registered live robot.
/// Error lists the registered names.
[[nodiscard]] Result<std::shared_ptr<RobotCore>> find_robot(const std::string& name);
/// Names of live robots in registration order.
[[nodiscard]] std::vector<std::string> robot_names();

}  // namespace visnav::sim
