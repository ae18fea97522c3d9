#!/usr/bin/env bash
# maptune's main job end to end on a fresh Debian 12 machine: installs dependencies, builds,
# generates a small simulated lab dataset, tunes the matcher's 9 parameters with all services
# in one process, and prints the best parameters next to the baseline with both scores.
# Extra arguments go to `maptune run` (e.g. --workers 2, --run-dir runs/mine).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release --target maptune
exec ./build/release/services/maptune/maptune run --experiment configs/experiments/demo.yaml "$@"
