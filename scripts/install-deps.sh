#!/usr/bin/env bash
# Installs the Debian packages visnav needs, only those that are missing.
# Runs apt-get directly as root, through sudo otherwise. Non-interactive (CI has no stdin).
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config
  libopencv-dev libopencv-contrib-dev libeigen3-dev
  cyclonedds-dev cyclonedds-tools libnlopt-cxx-dev libnlopt-dev
  libtinyxml2-dev libyaml-cpp-dev libzstd-dev liblz4-dev libgtest-dev libgmock-dev libbenchmark-dev
  python3-skimage openssl)
# `make fuzz` only (VISNAV_FUZZ=1): clang with the libFuzzer runtime.
if [ "${VISNAV_FUZZ:-0}" = 1 ]; then packages+=(clang libclang-rt-14-dev); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "visnav: installing missing packages: ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
