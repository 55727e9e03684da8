// Internal: registration of the built-in node families (see register_builtin_nodes()).
#pragma once

#include "visnav/bt/registry.hpp"

namespace visnav::bt::detail {

Status register_builtin_controls(NodeRegistry& registry);
Status register_builtin_decorators(NodeRegistry& registry);
Status register_builtin_actions(NodeRegistry& registry);
Status register_builtin_script_nodes(NodeRegistry& registry);

}  // namespace visnav::bt::detail
