#!/usr/bin/env bash
# Checks that every tracked C++ file (*.cpp, *.h) is laid out as the committed .clang-format says
# (clang-format 14, Debian 12's): prints each difference and exits non-zero when there is one.
# Fix with `git clang-format` (changed lines) or `clang-format -i FILE`.
set -euo pipefail
cd "$(dirname "$0")/.."
git ls-files -z '*.cpp' '*.h' | xargs -0 clang-format --dry-run -Werror
