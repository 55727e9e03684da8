// The `camera_sim` plugin: camera type `sim`, rendering the world of a `sim` robot.
// The implementation lives in libvisnav_sim (visnav_sim/camera.hpp).
#include "visnav/plugin.hpp"
#include "visnav_sim/camera.hpp"

namespace {
const visnav::TypeEntry kTypes[] = {visnav::make_type<visnav::sim::SimCamera>(
    "sim", "pinhole camera rendering the sim robot's textured world (appearance changes, faults)")};
}  // namespace

VISNAV_PLUGIN(visnav::PluginKind::camera, "camera_sim", "0.1.0", "simulated camera (textured-world renderer)", kTypes, 1,
              nullptr, nullptr, 0)
