#!/usr/bin/env bash
# Builds the libFuzzer harnesses (fuzz/, preset `fuzz`: clang with ASan + UBSan) and runs each
# on a copy of its seed corpus (fuzz/corpus/<harness>) for a while.
#
#   bash scripts/fuzz.sh [--seconds S] [--jobs J] [HARNESS ...]
#
#   --seconds S  time per harness (default 5: the CI smoke run; use 600 for a real search)
#   --jobs J     harnesses run side by side (default 2)
#   HARNESS      cloud tum octree config messages (default: all)
#
# A crash, leak, timeout (10 s per input) or undefined behaviour fails the script; the input
# that caused it is kept in build/fuzz/findings/<harness>/ — add it to the harness's corpus as
# its regression input once fixed. Prints executions per harness.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=5 jobs=2 harnesses=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    -*) echo "fuzz: unknown option '$1'" >&2; exit 2 ;;
    *) harnesses+=("$1"); shift ;;
  esac
done
[ ${#harnesses[@]} -gt 0 ] || harnesses=(cloud tum octree config messages)
command -v clang++ >/dev/null || { echo "fuzz: clang++ missing (bash scripts/install-deps.sh --test)" >&2; exit 1; }

[ -f build/fuzz/CMakeCache.txt ] || cmake --preset fuzz >/dev/null
cmake --build --preset fuzz --target "${harnesses[@]/#/fuzz_}" >/dev/null

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run_one() {
  local h=$1 corpus="$work/$1" findings="build/fuzz/findings/$1"
  mkdir -p "$corpus" "$findings"
  cp -r "fuzz/corpus/$h/." "$corpus/"
  # -rss_limit_mb: a reader that allocates without bound is a finding, not an OOM of the machine.
  # TMPDIR: the harnesses' scratch files go where the EXIT trap removes them.
  if TMPDIR="$work" build/fuzz/fuzz/fuzz_"$h" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
       -artifact_prefix="$findings/" -print_final_stats=1 >"$work/$h.log" 2>&1; then
    echo "fuzz_$h: $(grep -m1 '^stat::number_of_executed_units' "$work/$h.log" | awk '{print $2}') executions in ${seconds} s, no finding"
  else
    echo "fuzz_$h: FINDING (input in $findings/)"
    grep -E "ERROR|SUMMARY|runtime error" "$work/$h.log" | head -5
    return 1
  fi
}
status=0
pids=()
for h in "${harnesses[@]}"; do
  run_one "$h" &
  pids+=($!)
  if [ ${#pids[@]} -ge "$jobs" ]; then
    wait "${pids[0]}" || status=1
    pids=("${pids[@]:1}")
  fi
done
for p in "${pids[@]}"; do wait "$p" || status=1; done
exit $status
