// `visnav reloc-experiment` (docs/relocalisation.md, "Measuring"): teaches a route in the
// simulator with every leg as a feature edge, then for each of N trials starts a fresh session
// (its own draw of every error model) at a random pose on the taught route (lateral and heading
// offsets drawn uniformly within the given bounds), runs Relocalise and classifies the answer
// against the ground truth of the teach run; the first R localised trials then replay from there
// to the end node of the following edge (trees/replay_from_here.xml) and count as completed when
// the run succeeds and ends within 1 m of where that node was taught.
#pragma once

#include "visnav/host.hpp"

namespace visnav::relocexp {

int run_reloc_experiment(int argc, char** argv, HostServices& host);

}  // namespace visnav::relocexp
