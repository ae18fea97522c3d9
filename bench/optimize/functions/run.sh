#!/bin/bash
# maptune optimize against Optuna's CMA-ES and TPE on the functions in objective.py, one
# compare.py run per function: bash bench/optimize/functions/run.sh [compare.py options]
# (default --seeds 10 --budget 100). Needs Debian's python3 with python3-optuna.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
py=${PYTHON:-/usr/bin/python3}
spaces=$(mktemp -d)
trap 'rm -rf "$spaces"' EXIT
for f in rastrigin schwefel michalewicz griewank dixon_price zakharov powell rotated_ellipsoid trid alpine sum_powers; do
    "$py" "$here/objective.py" --space "$f" > "$spaces/$f.yaml"
    "$py" "$here/../compare.py" --space "$spaces/$f.yaml" --objective-cmd "$py $here/objective.py $f" \
        --minimum "$("$py" "$here/objective.py" --minimum "$f")" --name "$f" --seeds 10 --budget 100 "$@"
done
