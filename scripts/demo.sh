#!/usr/bin/env bash
# `make demo`: the main job on the built-in simulated robot — the seed 000 experiment on the
# mixed indoor/outdoor campus, with the simulator's realistic error models on. For each of
# 5 seeds it teaches the 150 m closed route from its script (hybrid map: feature edges in the
# hall and across the square, path-following edges on the gravel paths; and a feature-only map
# of the same route) with one draw of the odometry/camera errors, carries the robot 1 m to the
# left of the first edge and turns it 10°, replays 5 loops with another draw, and prints loops
# completed, ε_acc / ε_rep as mean ± sd (worst) over the seeds, collisions and lost stops.
# Pictures and per-run files go to out/experiment/.
#   scripts/demo.sh BUILD_DIR [extra `visnav experiment` options, e.g. --seeds 3]
set -euo pipefail
build="${1:-build}"
shift || true
root="$(cd "$(dirname "$0")/.." && pwd)"
visnav="$build/bin/visnav"
if [ ! -x "$visnav" ]; then echo "demo: $visnav is not built (run 'make build')" >&2; exit 1; fi
cd "$root"
# Exit status 1 means some loop failed: the table says which; the demo still succeeded.
status=0
"$visnav" experiment --world campus --route campus --displace 1.0,10 --loops 5 --seeds 5 \
  --config config/sim_experiment.yaml --out out/experiment "$@" || status=$?
if [ "$status" -gt 1 ]; then exit "$status"; fi
echo "demo: done (every figure above was measured with the error models on; see out/experiment/report.md)"
