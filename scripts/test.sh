#!/usr/bin/env bash
# Every test on a fresh Debian 12 machine (as root): install what is needed, build with warnings
# as errors, run the whole suite through CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DPNSPLAT_WERROR=ON
ctest --test-dir build --output-on-failure -j "$(nproc)"
