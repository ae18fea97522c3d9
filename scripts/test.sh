#!/usr/bin/env bash
# Runs the whole test suite from a clean clone: installs dependencies, builds (Release), runs
# ctest. Extra arguments go to ctest (e.g. -R store).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh --test
cmake --preset release
cmake --build --preset release
ctest --preset release "$@"
