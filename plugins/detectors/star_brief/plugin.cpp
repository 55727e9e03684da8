// Detector plugin: star_brief — the CenSurE/STAR detector and BRIEF-256 descriptor of this
// project (plugins/detectors/common), with adaptive threshold and upright option — and grief,
// the same with trained comparison pairs (`pairs:` seasonal = the pattern that ships, built in;
// or a file from `visnav train-descriptor`; brief = BRIEF's).
#include "visnav/detectors/detector_types.hpp"
#include "visnav/plugin.hpp"

namespace {

const visnav::TypeEntry kTypes[] = {
    visnav::make_type<visnav::detectors::StarBriefDetector>(
        "star_brief", "CenSurE/STAR keypoints + 256-bit BRIEF (upright by default), adaptive threshold"),
    visnav::make_type<visnav::detectors::GriefDetector>(
        "grief", "CenSurE/STAR keypoints + 256-bit GRIEF (BRIEF with trained comparison pairs, `pairs:`; default: the shipped "
        "seasonal pattern)"),
};

}  // namespace

VISNAV_PLUGIN({.name = "detector_star_brief",
               .version = "1.0",
               .description = "CenSurE/STAR + BRIEF detector written in visnav",
               .types = kTypes})
