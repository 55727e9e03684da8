// visnav behaviour trees — umbrella header (ports, blackboard, nodes, coroutine actions, registry, tree).
#pragma once

#include "visnav/bt/blackboard.hpp"
#include "visnav/bt/coro_action.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
