#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine (as root): install what is needed, build the `pnsplat`
# program only (not the tests), and show what it is for on the embedded default model (a sparse,
# coloured surface with ridges and thin horns, generated in code):
#  - out/default.png: one camera, three panels — the input as points, the input as splats, and the
#    refinement for that camera by the real-time engine (`render --compare`), with how close each
#    splat panel comes to a render of the same surface sampled densely (PSNR);
#  - the real-time engine along a short orbit of the model (`bench view`): its summary line.
# Environment: as scripts/build.sh (BUILD_DIR, CMAKE_BUILD_PARALLEL_LEVEL, ...).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# The program alone, its files compiled as one (PNSPLAT_UNITY_TOOLS: CLI11 compiled once).
BUILD_TARGET=pnsplat bash scripts/build.sh -DPNSPLAT_UNITY_TOOLS=ON
pnsplat=${BUILD_DIR:-build}/tools/pnsplat
mkdir -p out
"$pnsplat" render --compare --width 640 --height 540 -o out/default.png
echo "bench view: the real-time engine along an orbit of the default model (96 frames, a turn, at 640x480;"
echo "one JSON line a frame in out/bench-view.jsonl), its summary:"
"$pnsplat" bench view --camera-path orbit --frames 96 >out/bench-view.jsonl
tail -n 1 out/bench-view.jsonl
echo "wrote out/default.png and out/bench-view.jsonl"
