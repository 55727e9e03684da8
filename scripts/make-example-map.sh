#!/usr/bin/env bash
# Regenerates maps/example, the small map shipped with visnav: a live teach on the simulated
# robot of the 20 m rectangle config/routes/curve20m_polygon.yaml in config/worlds/curve20m.yaml
# (four feature_segment edges, closed at the start node), with the robot's and camera's default
# seeds so the teach is repeatable. The teach tree also writes the map's place index
# (place_index.bin, docs/relocalisation.md). The payloads are only ever written by this script; never
# edit them by hand. `make test` validates the result and replays it (tests/integration/maps).
#   scripts/make-example-map.sh [BUILD_DIR] [OUT_DIR]     (defaults: build, maps/example)
set -euo pipefail
build="${1:-build}"
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${2:-$root/maps/example}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
visnav="$build/bin/visnav"
if [ ! -x "$visnav" ]; then echo "make-example-map: $visnav is not built (run 'make build')" >&2; exit 1; fi
cd "$root"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
taught="$tmp/$(basename "$out")"  # the map's name is its folder's name
"$visnav" run --config config/sim_feature.yaml --tree trees/teach_hybrid_route.xml --map "$taught" --create \
  --set run.log_level=warn --set "nodes=[feature_replay, navigation, sim_operator, path_following, relocalisation]" \
  --bb route_file=config/routes/curve20m_polygon.yaml --bb force_kind=feature_segment --bb close_loop=true
"$visnav" map validate "$taught"
rm -rf "$out"
mkdir -p "$(dirname "$out")"
mv "$taught" "$out"
echo "make-example-map: wrote $out"
