// libvisnav_reloc_experiment.so — the `visnav reloc-experiment` command (reloc_experiment.hpp).
#include "reloc_experiment.hpp"
#include "visnav/plugin.hpp"

namespace {

const visnav::CommandEntry kCommands[] = {
    {"reloc-experiment",
     "relocalisation from random start poses on a taught simulator route: correct / ambiguous / wrong rates, "
     "then replay from there",
     &visnav::guarded_command<&visnav::relocexp::run_reloc_experiment>},
};

}  // namespace

VISNAV_PLUGIN({.name = "reloc_experiment",
               .version = "0.1.0",
               .description = "Relocalisation experiment in the simulator (issue 21): reloc-experiment",
               .commands = kCommands})
