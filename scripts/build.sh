#!/usr/bin/env bash
# Configures and builds pnsplat in build/ (Release, Ninja). Extra arguments go to CMake, e.g.
#   scripts/build.sh -DPNSPLAT_WERROR=ON
# Environment: BUILD_DIR (default build), BUILD_TYPE (default Release), BUILD_TARGET (default:
# everything; scripts/demo.sh builds the `pnsplat` program only), and CMake's own
# CMAKE_GENERATOR (default Ninja) and CMAKE_BUILD_PARALLEL_LEVEL (default: one job per processor;
# Make would otherwise run one job). A folder configured before with another generator is
# configured afresh (CMake refuses to switch).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
export CMAKE_GENERATOR=${CMAKE_GENERATOR:-Ninja}
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
fresh=()
if [ -f "$build_dir/CMakeCache.txt" ] &&
  ! grep -qx "CMAKE_GENERATOR:INTERNAL=$CMAKE_GENERATOR" "$build_dir/CMakeCache.txt"; then
  fresh=(--fresh)
fi
cmake "${fresh[@]}" -S . -B "$build_dir" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" "$@" >/dev/null
cmake --build "$build_dir" ${BUILD_TARGET:+--target "$BUILD_TARGET"}
