#!/usr/bin/env bash
# `make demo`: a small mission on the fixture robot and camera, run with `visnav run`.
# (The simulator issue replaces this with the simulated robot on a taught route.)
#   scripts/demo.sh BUILD_DIR
set -euo pipefail
build="${1:-build}"
root="$(cd "$(dirname "$0")/.." && pwd)"
visnav="$build/bin/visnav"
fixtures="$build/lib/visnav/plugins/fixtures"
config="$root/tests/fixtures/demo/setup.yaml"
tree="$root/tests/fixtures/demo/mission.xml"

if [ ! -x "$visnav" ]; then echo "demo: $visnav not built (run 'make build')" >&2; exit 1; fi
if [ ! -f "$fixtures/libvisnav_fixture_robot.so" ]; then
  echo "demo: fixture plugins missing in $fixtures (configure with VISNAV_BUILD_TESTS=ON)" >&2; exit 1
fi

out="$(mktemp -d "${TMPDIR:-/tmp}/visnav_demo.XXXXXX")"
echo "== visnav validate"
"$visnav" validate --config "$config" --tree "$tree" --plugin-path "$fixtures"
echo "== visnav run (lock-step simulation of the fixture robot)"
status=0
"$visnav" run --config "$config" --tree "$tree" --plugin-path "$fixtures" \
  --set run.telemetry_file="$out/telemetry.jsonl" --trace "$out/trace.jsonl" || status=$?
echo "== result"
echo "exit status:        $status"
echo "ticks (telemetry):  $(wc -l <"$out/telemetry.jsonl")"
echo "status transitions: $(wc -l <"$out/trace.jsonl")"
echo "last telemetry:     $(tail -n 1 "$out/telemetry.jsonl")"
echo "files:              $out/telemetry.jsonl $out/trace.jsonl"
exit "$status"
