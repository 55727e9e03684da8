// `visnav align` — horizontal offset between two images by histogram voting (issue 4, item 6).
#pragma once

#include "visnav/host.hpp"

namespace visnav::feature_replay {

/// Usage text of the command.
extern const char* const kAlignUsage;

/// Runs `visnav align` (argv[0] == "align"). Returns the process exit status: 0 ok, 1 a pair
/// failed (image unreadable, detector error), 2 usage error.
int run_align(int argc, char** argv, HostServices& host);

}  // namespace visnav::feature_replay
