#!/usr/bin/env bash
# Coverage-guided fuzzing (libFuzzer, Clang, ASan + UBSan) of the PLY reader, of the PCD and text
# readers (fuzz_points) and of the whole refinement pipeline (tests/fuzz): `scripts/fuzz.sh [SECONDS]` runs each target that long
# (default 120) from a corpus of small valid files that fuzz_seeds writes. A crash, a failed
# check, a leak, a hang (10 s on one input) or memory beyond 2 GiB stops it with a non-zero exit;
# the input is saved in build-fuzz/artifacts/ (replay: build-fuzz/tests/fuzz/fuzz_TARGET FILE).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-120}
bash scripts/install-deps.sh fuzz
# Debug keeps the asserts (-O1 for speed), as scripts/sanitize.sh does.
CXX=clang++ cmake -G Ninja -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
  -DPNSPLAT_FUZZ=ON -DPNSPLAT_SANITIZE=address -DPNSPLAT_BUILD_TESTS=OFF -DPNSPLAT_WERROR=ON >/dev/null
cmake --build build-fuzz --target fuzz_ply fuzz_points fuzz_refine fuzz_seeds
rm -rf build-fuzz/corpus build-fuzz/artifacts
mkdir -p build-fuzz/artifacts
./build-fuzz/tests/fuzz/fuzz_seeds build-fuzz/corpus/seeds-ply build-fuzz/corpus/seeds-refine \
  build-fuzz/corpus/seeds-points
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
for target in ply points refine; do
  mkdir -p "build-fuzz/corpus/$target"
  # New inputs go to the first folder; the seeds are read from the second.
  ./build-fuzz/tests/fuzz/fuzz_$target -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="build-fuzz/artifacts/$target-" \
    "build-fuzz/corpus/$target" "build-fuzz/corpus/seeds-$target" 2>&1 | grep -v -E '^(#[0-9]+|\s+NEW_FUNC|"|######)'
done
