// The thesis rig at its processing resolution (spec §9.1): 256×192, f = 3.72 mm / 18.6 µm
// = 200 px, lens 0.43 m up, pitched 9° down.
#pragma once

#include <cmath>

#include "visnav/ipt_obstacles/ipt.hpp"

namespace visnav::ipt::testing {

inline IptCamera thesis_rig() {
  IptCamera c;
  c.width_px = 256;
  c.height_px = 192;
  c.fx_px = 200.0;
  c.fy_px = 200.0;
  c.cx_px = 128.0;
  c.cy_px = 96.0;
  c.height_m = 0.43;
  c.pitch_rad = -9.0 * CV_PI / 180.0;
  return c;
}

}  // namespace visnav::ipt::testing
