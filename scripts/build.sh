#!/usr/bin/env bash
# Configures and builds pnsplat in build/ (Release). Extra arguments go to CMake, e.g.
#   scripts/build.sh -DPNSPLAT_WERROR=ON
# Environment: BUILD_DIR (default build), BUILD_TYPE (default Release).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
cmake -G Ninja -S . -B "$build_dir" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" "$@" >/dev/null
cmake --build "$build_dir"
