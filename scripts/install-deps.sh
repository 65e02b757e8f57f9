#!/usr/bin/env bash
# Installs everything pnsplat needs to build, run and test on Debian 12 (run as root);
# `install-deps.sh fuzz` adds Clang and its libFuzzer runtime (scripts/fuzz.sh).
# Debian's packages only; nothing is downloaded from anywhere else.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang-format
  libglm-dev libgtest-dev googletest
  libnanoflann-dev libcli11-dev libfmt-dev libstb-dev
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers glslang-tools
  libglfw3-dev xvfb
)
if [ "${1:-}" = fuzz ]; then
  packages+=(clang libclang-rt-14-dev)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
