#!/usr/bin/env bash
# Runs every libFuzzer target in BUILD/bin for FUZZ_S seconds each on its corpus (fuzz/corpus/<name>,
# without the "fuzz_" prefix; new inputs go to BUILD/fuzz-corpus/<name>, the checked-in corpus is
# only read). Exit 1 if any target finds a crash (its reproducer is left in BUILD/fuzz-artifacts).
# Usage: scripts/fuzz.sh BUILD FUZZ_S
set -u
build=${1:-build-fuzz}
seconds=${2:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
status=0
mkdir -p "$build/fuzz-artifacts"
for bin in "$build"/bin/fuzz_*; do
  [ -x "$bin" ] || continue
  name=$(basename "$bin")
  corpus_name=${name#fuzz_}
  work="$build/fuzz-corpus/$corpus_name"
  mkdir -p "$work"
  seeds=()
  [ -d "$root/fuzz/corpus/$corpus_name" ] && seeds+=("$root/fuzz/corpus/$corpus_name")
  echo "== $name: ${seconds} s"
  if ! "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="$build/fuzz-artifacts/$name-" "$work" "${seeds[@]}" > "$build/fuzz-artifacts/$name.log" 2>&1; then
    echo "   FAILED: see $build/fuzz-artifacts/$name.log"; tail -n 30 "$build/fuzz-artifacts/$name.log"
    status=1
  else
    grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$build/fuzz-artifacts/$name.log" | tr '\n' ' '; echo
  fi
done
exit $status
