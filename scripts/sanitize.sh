#!/usr/bin/env bash
# The suite again under a sanitizer: `scripts/sanitize.sh address` (ASan + UBSan) or
# `scripts/sanitize.sh thread` (TSan). Builds in build-<sanitizer>/ (Debug, asserts on); the
# suite includes the install-and-consume test (tests/consumer).
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:?usage: scripts/sanitize.sh address|thread}
# The address build uses CMake's default generator on Linux, Unix Makefiles; the thread build and
# scripts/test.sh use Ninja. CI so builds with both generators, and in Debug, without extra builds.
if [ "$kind" = address ]; then
  export CMAKE_GENERATOR=${CMAKE_GENERATOR:-Unix Makefiles}
fi
# A build from scratch: the tests' library headers precompiled, and for the address build the
# program's files compiled as one (the address build, Unix Makefiles, 2-core AMD EPYC: 580 -> 515 s
# with both). Not one file for the thread build: compiled so under TSan, GCC's -Wnull-dereference
# fires in CLI11's inlined string code, an error with PNSPLAT_WERROR. scripts/test.sh builds as a
# user does.
faster=(-DPNSPLAT_PCH_TESTS=ON)
if [ "$kind" = address ]; then
  faster+=(-DPNSPLAT_UNITY_TOOLS=ON)
fi
# Debug keeps the asserts; -O1 keeps the acceptance-size tests within minutes.
BUILD_DIR="build-$kind" BUILD_TYPE=Debug bash scripts/build.sh -DPNSPLAT_SANITIZE="$kind" -DPNSPLAT_WERROR=ON \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" "${faster[@]}"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
# The Vulkan loader unloads lavapipe when an instance is destroyed; memory lavapipe still
# references from its own globals then looks leaked to LeakSanitizer (112 bytes after a graphics
# pipeline). Preloading the driver keeps it mapped until exit, which leaves no leak to report.
# ASan must otherwise come first among the loaded libraries, hence verify_asan_link_order=0.
lavapipe=/usr/lib/$(gcc -print-multiarch)/libvulkan_lvp.so
if [ "$kind" = address ] && [ -e "$lavapipe" ]; then
  export LD_PRELOAD=$lavapipe
  export ASAN_OPTIONS=$ASAN_OPTIONS:verify_asan_link_order=0
fi
# Blocks lavapipe itself never frees (scripts/lsan.supp says which and why).
export LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/tsan.supp
# Under TSan, the tests that measure the accuracy of a whole refinement or picture on large inputs
# are left out; they run in release and under ASan. TSan slows them 10 to 45 times and they add no
# thread interleaving of their own: the worker pool, the tile graph and the parallel loops they
# run are run under TSan by RefinerDeterminism (1 to 8 threads), RefinerCreases.Cylinder*,
# NodeTree, the other NormalEstimation, HoleFilling and CliRender tests, and every Engine, Viewer
# and cache test. On a 2-core AMD EPYC under TSan, the lockstep comparison of settled pictures
# with the offline refinement took 558 of the suite's 2,823 test-seconds (2026-11-27); without it,
# the other ten took 616 of 1,927 (2026-11-28); the seven real models' comparisons with the
# centroid baseline took 290 and the data's filled holes 37 of 1,847 (2026-11-29); bench settle's
# comparisons (a torus refined offline to 243,000 points twice) 86 of 1,254 (2026-11-30).
skip=()
if [ "$kind" = thread ]; then
  accuracy=(
    'EngineTest\.SettledPictureMatchesTheOfflineRefinement'
    'RefinerRobustness\.TwoCornersOfOneTriangleMakeOnePoint'
    'CliRender\.CompareShowsThreePanelsAndTheRefinementIsCloserToTheDenseRender'
    'NormalEstimation\.ReferenceModelsAndTheirSubsetsFaceOutward'
    'RefinerCreases\.FandiskIsCloserToItsMeshWithCreaseNormals'
    'HoleFilling\.SphereHoleIsFilledNearTheSphere'
    'GoldenTest\.RefinedSparseModelIsCloserToTheDenseRender'
    'RefinerSphere\.UniformSphereTo150kIsAccurateUniformAndInterpolating'
    'CliRefine\.FillHolesFindsTheHoleAndFillsIt'
    'FlippedNormals\.DataModelsRefineAsTheCleanOnes'
    'RefinerTorus\.RandomTorusBeatsCentroidBaseline'
    'RefinerData/RefinerRealModel\.FullMethodBeatsCentroidBaseline/.*'
    'HoleFilling\.DataHolesAreFilled'
    'CliBenchSettle\.ComparesTheSettledPictureWithTheOfflineRefinement'
  )
  skip=(-E "^($(IFS='|'; echo "${accuracy[*]}"))\$")
fi
ctest --test-dir "build-$kind" --output-on-failure -j "$(nproc)" "${skip[@]}"
