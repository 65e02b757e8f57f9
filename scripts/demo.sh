#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine (as root): install what is needed, build, refine the
# embedded default model (a coloured, sparse, curved surface generated in code) and render it
# before and after (Vulkan; lavapipe where there is no GPU).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
mkdir -p out
./build/tools/pnsplat refine --levels 4 -o out/default-refined.ply
# The paper's point in two pictures: the sparse input splatted directly, and after refinement.
./build/tools/pnsplat render -o out/default-sparse.png
./build/tools/pnsplat render out/default-refined.ply -o out/default-refined.png
echo "wrote out/default-refined.ply, out/default-sparse.png and out/default-refined.png"
