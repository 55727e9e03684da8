// `visnav pathseg IMG [--draw stages.png] [--set key=value ...]` — runs the path follower on one
// image, prints status, v, ω and the path's area share, optionally draws the stages (Fig. 2).
#pragma once

#include "visnav/host.hpp"

namespace visnav::path_following {

inline constexpr const char* kPathsegUsage =
    "usage: visnav pathseg IMG [--draw STAGES.png] [--set key=value ...]\n"
    "  Runs the segmentation-based path follower (seed 000 Sec. 4) on one image and prints\n"
    "  status, v (m/s), omega (rad/s, counter-clockwise positive) and the path's area share.\n"
    "  --draw PATH      write the pipeline stages side by side (input + horizon, superpixels,\n"
    "                   reference region, classification, path + steering)\n"
    "  --set key=value  override a path follower parameter (see docs/path_following.md)\n"
    "Exit status: 0 processed (whatever the path status), 1 error, 2 usage.\n";

/// Entry of the `pathseg` command (argv[0] is the command name).
int run_pathseg(int argc, char** argv, HostServices& host);

}  // namespace visnav::path_following
