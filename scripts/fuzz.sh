#!/usr/bin/env bash
# Runs every libFuzzer target in BUILD/bin for FUZZ_S seconds each on its corpus (fuzz/corpus/<name>,
# without the "fuzz_" prefix; new inputs go to BUILD/fuzz-corpus/<name>, the checked-in corpus is
# only read). Exit 1 if any target finds a crash, leak, timeout or out-of-memory: the path of each
# crashing input (kept in BUILD/fuzz-artifacts) is printed with the command that reproduces it.
# Usage: scripts/fuzz.sh BUILD FUZZ_S
set -u
# Undefined behaviour in the fuzz targets themselves (the libraries abort on it already) is a
# finding too, not a line in the log.
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
build=${1:-build-fuzz}
seconds=${2:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
status=0
targets=0
mkdir -p "$build/fuzz-artifacts"
for bin in "$build"/bin/fuzz_*; do
  [ -x "$bin" ] || continue
  name=$(basename "$bin")
  targets=$((targets + 1))
  corpus_name=${name#fuzz_}
  work="$build/fuzz-corpus/$corpus_name"
  mkdir -p "$work"
  seeds=()
  [ -d "$root/fuzz/corpus/$corpus_name" ] && seeds+=("$root/fuzz/corpus/$corpus_name")
  echo "== $name: ${seconds} s"
  rm -f "$build/fuzz-artifacts/$name-"*
  # -timeout: a hang, not a slow input: the seed world of fuzz_world_route renders its procedural
  # textures in 4.2 s of CPU in this instrumented build (17 s of wall time on a loaded machine).
  if ! "$bin" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="$build/fuzz-artifacts/$name-" "$work" "${seeds[@]}" > "$build/fuzz-artifacts/$name.log" 2>&1; then
    echo "   FAILED: see $build/fuzz-artifacts/$name.log"; tail -n 30 "$build/fuzz-artifacts/$name.log"
    found=0
    for input in "$build/fuzz-artifacts/$name-"*; do
      [ -f "$input" ] || continue
      found=1
      echo "   crashing input: $input"
      echo "   reproduce:      $bin $input"
    done
    [ $found = 1 ] || echo "   no crashing input written (the fuzzer itself failed to start?)"
    status=1
  else
    grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$build/fuzz-artifacts/$name.log" | tr '\n' ' '; echo
  fi
done
# No target at all (clang missing, VISNAV_BUILD_FUZZERS off) must not pass as "no crash".
if [ $targets -eq 0 ]; then echo "no fuzz target in $build/bin (configure with VISNAV_BUILD_FUZZERS=ON and clang)"; exit 1; fi
exit $status
