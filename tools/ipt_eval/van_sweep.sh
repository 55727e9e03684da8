#!/usr/bin/env bash
# Replay-with-avoidance sweep (issue 16, docs/obstacles.md): teaches a 12 m feature edge on the
# clear gravel path of config/worlds/van_path.yaml once, then replays it with
# trees/replay_route_avoiding.xml with a parked van at each position and each seed (robot and
# camera noise), and prints one line per run: position, seed, exit status, collisions (from the
# sim robot's log), whether the detour ended, the edge distance where it resumed, the final
# true pose. Replays add sensor noise (2 grey levels) and odometry noise per seed. Usage (from the source root, after a build):
#   tools/ipt_eval/van_sweep.sh [build] "6.5,0.3 6.5,0 ..." "1 2 3"
set -u
build=${1:-build}
end_x=${END_X:-12}
positions=${2:-"6.5,0.3 6.5,0.0 6.5,-0.3 7.5,0.3 8.0,0.0 5.5,0.2"}
extra=${4:-}
seeds=${3:-"1 2 3"}
cli="$build/bin/visnav"
tree=${TREE:-trees/replay_route_avoiding.xml}
plugins="$build/lib/visnav/plugins"
out=$(mktemp -d /tmp/van_sweep.XXXXXX)
world=config/worlds/van_path.yaml
printf 'route:\n  name: line\n  start: [0, 0, 0]\n  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [%s, 0]}\n' "$end_x" > "$out/route.yaml"
"$cli" run --plugin-path "$plugins" --config config/sim_obstacles.yaml --tree trees/teach_feature_edge.xml \
  --set robot.params.world="$PWD/$world" --map "$out/map" --create --bb route_file="$out/route.yaml" \
  --bb style=segment --bb force_kind=feature_segment --bb close_loop=false > "$out/teach.log" 2>&1 ||
  { echo "teach failed: $out/teach.log"; exit 1; }
total=0; ok=0; hits=0
for pos in $positions; do
  x=${pos%,*}; y=${pos#*,}
  { cat "$world"; printf '  obstacles:\n    - {name: van, kind: van, at: [%s, %s], texture: van}\n' "$x" "$y"; } > "$out/van_$pos.yaml"
  for seed in $seeds; do
    log="$out/replay_${pos}_$seed.log"
    "$cli" run --plugin-path "$plugins" --config config/sim_obstacles.yaml --tree "$tree" \
      --set robot.params.world="$out/van_$pos.yaml" --set robot.params.seed="$seed" --set camera.params.seed="$seed" --set camera.params.noise_std=2 --set robot.params.odom_distance_noise_m_per_sqrt_m=0.005 --set robot.params.odom_heading_noise_deg_per_sqrt_m=0.3 \
      --map "$out/map" --bb start=start --bb goal=n1 --bb detour_m=8 $extra > "$log" 2>&1
    st=$?
    c=$(grep -c "collision with" "$log")
    resumed=$(grep -o "the edge resumes at [0-9.]*" "$log" | tail -1 | awk '{print $5}')
    why=$(grep -o "stopped: [^(]*" "$log" | head -1)
    total=$((total + 1)); [ "$st" = 0 ] && [ "$c" = 0 ] && ok=$((ok + 1)); hits=$((hits + c))
    echo "van ($x, $y) seed $seed: exit $st, collisions $c, resumed ${resumed:--} ${why}"
  done
done
echo "completed without collision: $ok of $total; collisions: $hits; logs in $out"
