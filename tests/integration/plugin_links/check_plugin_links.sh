#!/usr/bin/env bash
# Every plugin a robot's mission loads must run without the simulator: `ldd` of each .so in the
# plugin directory shows no libvisnav_sim, except for the simulator itself and the simulator
# tools (the scripted operator with `visnav experiment`/`benchmark`, the relocalisation
# experiment, the IPT evaluation commands). Usage: check_plugin_links.sh PLUGIN_DIR
set -euo pipefail
dir="${1:?usage: check_plugin_links.sh PLUGIN_DIR}"
allowed=" libvisnav_simulator.so libvisnav_sim_operator.so libvisnav_reloc_experiment.so libvisnav_ipt_eval.so "
checked=0
bad=()
for so in "$dir"/libvisnav_*.so; do
  name="$(basename "$so")"
  [[ "$allowed" == *" $name "* ]] && continue
  checked=$((checked + 1))
  if ldd "$so" | grep -q 'libvisnav_sim\.so'; then bad+=("$name"); fi
done
if [ "$checked" -lt 10 ]; then echo "only $checked navigation plugins found in $dir (expected the built set)" >&2; exit 1; fi
if [ "${#bad[@]}" -gt 0 ]; then echo "navigation plugins linking the simulator: ${bad[*]}" >&2; exit 1; fi
echo "$checked navigation plugins, none links the simulator"
