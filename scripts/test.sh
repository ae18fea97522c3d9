#!/usr/bin/env bash
# Runs the whole test suite from a clean clone: installs dependencies, builds (Release), runs
# ctest, then the fuzz harnesses on their corpora for a few seconds each (a smoke run, not a
# search: scripts/fuzz.sh --seconds 600 is that). Extra arguments go to ctest (e.g. -R store)
# and skip the fuzz run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh --test
cmake --preset release
cmake --build --preset release
ctest --preset release "$@"
if [ $# -eq 0 ]; then bash scripts/fuzz.sh --seconds 5; fi
