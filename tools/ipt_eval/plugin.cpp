// libvisnav_ipt_eval.so — the IPT obstacle detector measured in the simulator (tools wing):
// `visnav ipt-roc`, `visnav ipt-ekf` and `visnav calibrate-ipt`. A commands-only plugin, so the
// navigation plugin libvisnav_ipt_obstacles.so does not link the simulator.
#include "cmd_calibrate_ipt.hpp"
#include "cmd_ipt_ekf.hpp"
#include "cmd_ipt_roc.hpp"
#include "visnav/plugin.hpp"

namespace {

const visnav::CommandEntry kCommands[] = {
    {"ipt-roc", "IPT obstacle/ground classifier on rendered frames: precision, recall, ROC AUC",
     &visnav::guarded_command<&visnav::ipt::run_ipt_roc>},
    {"ipt-ekf", "the robocentric EKF on the IPT pipeline's ground features along a rendered run: drift and NEES",
     &visnav::guarded_command<&visnav::ipt::run_ipt_ekf>},
    {"calibrate-ipt", "camera height and pitch for the IPT from flat-ground frames (NLopt), in the simulator",
     &visnav::guarded_command<&visnav::ipt::run_calibrate_ipt>},
};

}  // namespace

VISNAV_PLUGIN({.name = "ipt_eval",
               .version = "0.1.0",
               .description = "IPT obstacle detection measured on rendered frames: classifier ROC, EKF drift, "
                              "camera calibration",
               .commands = kCommands})
