#!/usr/bin/env bash
# `make demo`: the main job on the built-in simulated robot — the seed 000 experiment on the
# mixed indoor/outdoor campus. Teaches the 150 m closed route from its script (hybrid map:
# feature edges in the hall and across the square, path-following edges on the gravel paths;
# and a feature-only map of the same route), displaces the robot 1 m, replays 5 loops with 3 %
# odometry scale error, and prints ε_acc / ε_rep and map sizes. Pictures go to out/experiment/.
#   scripts/demo.sh BUILD_DIR [extra `visnav experiment` options]
set -euo pipefail
build="${1:-build}"
shift || true
root="$(cd "$(dirname "$0")/.." && pwd)"
visnav="$build/bin/visnav"
if [ ! -x "$visnav" ]; then echo "demo: $visnav is not built (run 'make build')" >&2; exit 1; fi
cd "$root"
exec "$visnav" experiment --world campus --route campus --displace 1.0 --loops 5 \
  --config config/sim_experiment.yaml --out out/experiment "$@"
