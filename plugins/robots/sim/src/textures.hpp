// Private: texture construction (image files and procedural generators) and mip pyramids.
#pragma once

#include <string>

#include "visnav/config_node.hpp"
#include "visnav/result.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim::detail {

/// Builds texture `name` from its YAML definition (keys in docs/sim.md). Seasons are not
/// resolved here (they name other textures).
[[nodiscard]] Result<Texture> make_texture(const std::string& name, const ConfigNode& def, const std::string& base_dir);

/// Fills texture.levels[1..] from levels[0] (2x2 box filter) and sets size_log2.
void build_mips(Texture& texture);

}  // namespace visnav::sim::detail
