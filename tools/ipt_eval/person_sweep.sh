#!/usr/bin/env bash
# Replay with a person crossing the taught path (issue 16, docs/obstacles.md): teaches a 12 m
# feature edge on the clear gravel path of config/worlds/van_path.yaml once, then replays it with
# trees/replay_route_avoiding.xml while a person (kind person, 1.75 m, radius 0.25 m) walks across
# the path at x = X from y = +4 to y = -4 at SPEED m/s, starting at START s of simulated time; one
# run per (start, seed) with sensor noise (2 grey levels) and odometry noise per seed. The person
# is placed per run with robot.params.obstacles (an obstacle file). Prints one line per run:
# exit status, collisions (sim robot log), whether the robot waited or detoured, final true pose.
# Usage (from the source root, after a build):
#   tools/ipt_eval/person_sweep.sh [build] "4 7 10" "1 2 3"
set -u
build=${1:-build}
starts=${2:-"4 7 10"}
seeds=${3:-"1 2 3"}
extra=${4:-}
x=${X:-6}
speed=${SPEED:-1.0}
cli="$build/bin/visnav"
tree=${TREE:-trees/replay_route_avoiding.xml}
plugins="$build/lib/visnav/plugins"
out=$(mktemp -d /tmp/person_sweep.XXXXXX)
world=config/worlds/van_path.yaml
printf 'route:\n  name: line\n  start: [0, 0, 0]\n  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [12, 0]}\n' > "$out/route.yaml"
"$cli" run --plugin-path "$plugins" --config config/sim_obstacles.yaml --tree trees/teach_feature_edge.xml \
  --set robot.params.world="$PWD/$world" --map "$out/map" --create --bb route_file="$out/route.yaml" \
  --bb style=segment --bb force_kind=feature_segment --bb close_loop=false > "$out/teach.log" 2>&1 ||
  { echo "teach failed: $out/teach.log"; exit 1; }
total=0; ok=0; hits=0
for start in $starts; do
  printf 'obstacles:\n  - {name: person, kind: person, at: [%s, 4], path: [[%s, -4]], speed_mps: %s, start_s: %s, texture: van}\n' \
    "$x" "$x" "$speed" "$start" > "$out/person_$start.yaml"
  for seed in $seeds; do
    log="$out/replay_${start}_$seed.log"
    "$cli" run --plugin-path "$plugins" --config config/sim_obstacles.yaml --tree "$tree" \
      --set robot.params.world="$PWD/$world" --set robot.params.obstacles="$out/person_$start.yaml" \
      --set robot.params.seed="$seed" --set camera.params.seed="$seed" --set camera.params.noise_std=2 \
      --set robot.params.odom_distance_noise_m_per_sqrt_m=0.005 --set robot.params.odom_heading_noise_deg_per_sqrt_m=0.3 \
      --map "$out/map" --bb start=start --bb goal=n1 --bb detour_m=8 $extra > "$log" 2>&1
    st=$?
    c=$(grep -c "collision with" "$log")
    waited=$(grep -c "the corridor is clear" "$log")
    detours=$(grep -c "m of the edge: detour" "$log")
    why=$(grep -o "stopped: [^(]*" "$log" | head -1)
    total=$((total + 1)); [ "$st" = 0 ] && [ "$c" = 0 ] && ok=$((ok + 1)); hits=$((hits + c))
    echo "person start ${start} s seed $seed: exit $st, collisions $c, waits $waited, detours $detours ${why}"
  done
done
echo "completed without collision: $ok of $total; collisions: $hits; logs in $out"
