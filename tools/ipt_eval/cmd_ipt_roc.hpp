// `visnav ipt-roc` — the IPT obstacle/ground classifier on frames rendered by the simulator
// with ground-truth labels: precision, recall, fall-out, ROC AUC, the β minimising
// FP + 0.5·FN, and optionally a picture of the classified features (issue 16).
#pragma once

#include "visnav/host.hpp"

namespace visnav::ipt {

extern const char* const kIptRocUsage;

/// Runs `visnav ipt-roc` (argv[0] == "ipt-roc"). Exit status: 0 done, 1 evaluation failed
/// (world not found, bad option value), 2 usage error.
int run_ipt_roc(int argc, char** argv, HostServices& host);

}  // namespace visnav::ipt
