// `visnav train-descriptor` — evolutionary training of GRIEF comparison pairs (issue 13).
#pragma once

#include "visnav/host.hpp"

namespace visnav::feature_replay {

/// Usage text of the command.
extern const char* const kTrainDescriptorUsage;

/// Runs `visnav train-descriptor` (argv[0] == "train-descriptor"). Exit status: 0 ok, 1 a data
/// or I/O error (message on stderr naming file:line), 2 usage error.
int run_train_descriptor(int argc, char** argv, HostServices& host);

}  // namespace visnav::feature_replay
