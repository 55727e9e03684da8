// `visnav ipt-ekf` — the thesis's robocentric EKF driven by the IPT pipeline's ground features
// (ground_odometry.hpp) on frames rendered by the simulator, against the wheel odometry it
// corrects: end errors and NEES over seeds (issue 16, "EKF consistency (NEES) on simulated runs").
#pragma once

#include "visnav/host.hpp"

namespace visnav::ipt {

extern const char* const kIptEkfUsage;

/// Runs `visnav ipt-ekf` (argv[0] == "ipt-ekf"). Exit status: 0 done, 1 evaluation failed
/// (world not found, bad option value), 2 usage error.
int run_ipt_ekf(int argc, char** argv, HostServices& host);

}  // namespace visnav::ipt
