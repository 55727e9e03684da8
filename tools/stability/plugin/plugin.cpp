// libvisnav_stability.so — convergence analysis and tuning commands (issue 19): no node types,
// only `visnav stability`, `visnav stability-sim`, `visnav tune`
// and `visnav platforms`.
#include "commands.hpp"
#include "visnav/plugin.hpp"

namespace {

const visnav::CommandEntry kCommands[] = {
    {"stability", "error model of a taught closed route: eigenvalues, per-loop contraction, verdict (seed 000 Sec. 5)",
     &visnav::guarded_command<&visnav::stability::stability_command>},
    {"stability-sim", "1,000,000 random routes replayed: does the error converge? (seed 002 Sec. 3.8)",
     &visnav::guarded_command<&visnav::stability::stability_sim_command>},
    {"tune", "NLopt (Sbplx) over primitive parameters, objective eps_acc + lambda*eps_rep from `visnav experiment`",
     &visnav::guarded_command<&visnav::stability::tune_command>},
    {"platforms", "seed 002 Table 1 in the simulator: one experiment per platform row (kinematics, rates, latency)",
     &visnav::guarded_command<&visnav::stability::platforms_command>},
};

}  // namespace

VISNAV_PLUGIN({.name = "stability",
               .version = "0.1.0",
               .description = "Convergence analysis (seed 000 Sec. 5, seed 002 Sec. 2.5/3.8) and parameter tuning",
               .commands = kCommands})
