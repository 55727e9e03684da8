// `visnav map-experiences MAP [--check]` (also reached as `visnav map experiences MAP`): lists the
// appearance experiences of every feature edge of a map and checks them (docs/feature_replay.md,
// "Multi-experience maps").
#pragma once

#include "visnav/host.hpp"

namespace visnav::feature_replay {

extern const char* const kExperiencesUsage;
int run_map_experiences(int argc, char** argv, HostServices& host);

}  // namespace visnav::feature_replay
