// `visnav calibrate-ipt` — camera height and pitch for the IPT from frames of flat ground
// (calibration.hpp), here on frames the simulator renders with a known mount, so the estimate
// can be compared with the truth (issue 16).
#pragma once

#include "visnav/host.hpp"

namespace visnav::ipt {

extern const char* const kCalibrateIptUsage;

/// Exit status: 0 done, 1 calibration failed (reason on stderr), 2 usage error.
int run_calibrate_ipt(int argc, char** argv, HostServices& host);

}  // namespace visnav::ipt
