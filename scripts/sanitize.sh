#!/usr/bin/env bash
# The suite again under a sanitizer: `scripts/sanitize.sh address` (ASan + UBSan) or
# `scripts/sanitize.sh thread` (TSan). Builds in build-<sanitizer>/ (Debug, asserts on).
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:?usage: scripts/sanitize.sh address|thread}
# Debug keeps the asserts; -O1 keeps the acceptance-size tests within minutes.
BUILD_DIR="build-$kind" BUILD_TYPE=Debug bash scripts/build.sh -DPNSPLAT_SANITIZE="$kind" -DPNSPLAT_WERROR=ON \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1
ctest --test-dir "build-$kind" --output-on-failure -j "$(nproc)"
