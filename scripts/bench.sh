#!/usr/bin/env bash
# `make bench`: runs every bench_* program in BUILD_DIR/bin, one after the other.
#   scripts/bench.sh BUILD_DIR [extra Google Benchmark arguments...]
# bench_map and bench_replay generate their maps once and keep them in $TMPDIR/visnav_bench_maps
# (~0.8 GB; delete the folder to free the space or to force regeneration).
set -euo pipefail
build="${1:-build}"
shift || true
shopt -s nullglob
benches=("$build"/bin/bench_*)
if [ ${#benches[@]} -eq 0 ]; then
  echo "bench: no bench_* programs in $build/bin (configure with VISNAV_BUILD_BENCHMARKS=ON)" >&2
  exit 1
fi
failed=0
for b in "${benches[@]}"; do
  [ -x "$b" ] || continue
  echo "== $(basename "$b")"
  "$b" "$@" || { echo "bench: $(basename "$b") failed" >&2; failed=1; }
done
exit "$failed"
