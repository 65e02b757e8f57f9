#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine (as root): install what is needed, build, refine the
# embedded default model (a coloured, sparse, curved surface generated in code) and measure it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
mkdir -p out
./build/tools/pnsplat refine --levels 4 -o out/default-refined.ply
echo "wrote out/default-refined.ply"
