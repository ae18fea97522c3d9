#!/usr/bin/env bash
# Fault injection for exactly-once results (issue 12). Runs one tuning experiment twice with
# the four services as separate processes and the real (PCL) matcher on a small simulated lab:
# once undisturbed, once while random services are SIGKILLed at random moments — while tasks
# are in flight, not only between evaluations — and restarted with the same arguments. Then
# compares the two runs' trials.csv and every observation in their stores: none lost, none
# duplicated, none attributed to other parameters. Exit 0 only when nothing differs and every
# planned kill happened.
#
#   bash scripts/fault-test.sh [--kills N] [--seed S] [--evaluations E] [--build DIR] [--keep]
#                              [--transport udp|shm]
#
# --kills N        random kills during the fault run (default 10)
# --seed S         dataset, optimizer and kill schedule seed (default 1)
# --evaluations E  evaluation budget of the experiment (default max(20, 2 N))
# --build DIR      build directory with the binaries (default build/release)
# --keep           keep the work directory (logs, runs, stores); printed at the end
# --transport T    udp (default: the default profile maptune_loopback) or shm (profile
#                  maptune_loopback_shm, UDP + shared memory, which Fast DDS 2.9 does not keep
#                  working for participants restarted after a SIGKILL: configs/dds/loopback.xml)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

KILLS=10 SEED=1 EVALS="" BUILD=build/release KEEP=0 TRANSPORT=udp
while [ $# -gt 0 ]; do
  case "$1" in
    --kills) KILLS=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --evaluations) EVALS=$2; shift 2 ;;
    --build) BUILD=$2; shift 2 ;;
    --keep) KEEP=1; shift ;;
    --transport) TRANSPORT=$2; shift 2 ;;
    -h|--help) sed -n 2,21p "$0"; exit 0 ;;
    *) echo "fault-test: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$KILLS$SEED${EVALS:-0}" in *[!0-9]*) echo "fault-test: --kills, --seed and --evaluations take whole numbers" >&2; exit 2 ;; esac
case "$TRANSPORT" in
  udp) export MAPTUNE_DDS_PROFILE=maptune_loopback ;;
  shm) export MAPTUNE_DDS_PROFILE=maptune_loopback_shm ;;
  *) echo "fault-test: --transport takes udp or shm" >&2; exit 2 ;;
esac
unset MAPTUNE_DDS_PROFILES  # the built-in profiles (configs/dds/loopback.xml)
[ -n "$EVALS" ] || EVALS=$(( 2 * KILLS > 20 ? 2 * KILLS : 20 ))
BIN="$BUILD/services"
CLI="$BIN/maptune/maptune"
for b in "$CLI" "$BIN/maptune_dataset_server" "$BIN/maptune_sample_db" "$BIN/maptune_matcher_worker" "$BIN/maptune_optimizer"; do
  [ -x "$b" ] || { echo "fault-test: $b is missing: build first (cmake --build --preset release)" >&2; exit 2; }
done

WORK=$(mktemp -d "${TMPDIR:-/tmp}/maptune-fault-XXXXXX")
SHM_BEFORE=$(ls /dev/shm 2>/dev/null | grep -E '^(sem\.)?fastrtps_' | sort || true)
RANDOM=$SEED  # the kill schedule is reproducible per seed (the moments still depend on timing)
declare -A PID=() ARGS=()

stop_all() {
  for s in "${!PID[@]}"; do kill -TERM "${PID[$s]}" 2>/dev/null || true; done
  for s in "${!PID[@]}"; do
    for _ in $(seq 100); do kill -0 "${PID[$s]}" 2>/dev/null || break; sleep 0.05; done
    kill -KILL "${PID[$s]}" 2>/dev/null || true
    wait "${PID[$s]}" 2>/dev/null || true
  done
  PID=()
}
cleanup() {
  stop_all
  # SIGKILLed participants leave their shared-memory segments behind: remove ours.
  comm -13 <(echo "$SHM_BEFORE") <(ls /dev/shm 2>/dev/null | grep -E '^(sem\.)?fastrtps_' | sort || true) |
    while read -r f; do [ -n "$f" ] && rm -f "/dev/shm/$f"; done
  if [ "$KEEP" = 1 ]; then echo "fault-test: work directory kept: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

start() {  # start NAME: (re)starts a service with its recorded arguments, output appended to its log
  local name=$1
  # shellcheck disable=SC2086
  ${ARGS[$name]} >>"$RUN_DIR/$name.log" 2>&1 &
  PID[$name]=$!
}

launch_run() {  # launch_run NAME DOMAIN: the four services of one run
  RUN_DIR="$WORK/$1"
  local d=$2
  mkdir -p "$RUN_DIR"
  ARGS[dataset_server]="$BIN/maptune_dataset_server --dataset $WORK/lab --domain $d"
  ARGS[sample_db]="$BIN/maptune_sample_db --db $RUN_DIR/observations.db --lease 3 --unserved-timeout 600 --cache $RUN_DIR/cache-sample_db --domain $d"
  ARGS[worker]="$BIN/maptune_matcher_worker --id w1 --threads 1 --cache $RUN_DIR/cache-worker --domain $d"
  ARGS[optimizer]="$BIN/maptune_optimizer --experiment $WORK/experiment.yaml --run-dir $RUN_DIR/run --wait 300 --resend 3 --cache $RUN_DIR/cache-optimizer --domain $d"
  for s in dataset_server sample_db worker optimizer; do start "$s"; done
}

optimizer_finished() {  # the optimizer exited and its run record says the budget is used
  ! kill -0 "${PID[optimizer]}" 2>/dev/null && grep -q '^state: finished' "$RUN_DIR/run/run.yaml" 2>/dev/null
}

wait_finished() {  # wait_finished TIMEOUT_S
  local end=$((SECONDS + $1))
  while [ $SECONDS -lt $end ]; do
    if ! kill -0 "${PID[optimizer]}" 2>/dev/null; then
      wait "${PID[optimizer]}" 2>/dev/null || true
      optimizer_finished && return 0
      echo "fault-test: the optimizer of $RUN_DIR stopped without finishing; see $RUN_DIR/optimizer.log" >&2
      tail -5 "$RUN_DIR/optimizer.log" >&2
      return 1
    fi
    sleep 0.2
  done
  echo "fault-test: $RUN_DIR did not finish within $1 s" >&2
  return 1
}

# A domain no other maptune process holds, leased as libs/dds/domain_lease.hpp does (an flock
# on <tmp>/maptune-dds-domains/N.lock, held by this shell until it exits): a test or embedded run
# on the same domain would answer this run's requests. SRANDOM leaves the kill schedule alone.
lease_domain() {
  local dir="${TMPDIR:-/tmp}/maptune-dds-domains" d fd
  mkdir -p "$dir"
  for _ in $(seq 1000); do
    d=$(( (SRANDOM % 200) + 1 ))
    exec {fd}>>"$dir/$d.lock"
    if flock -n "$fd"; then DOMAIN=$d; return 0; fi
    exec {fd}>&-
  done
  echo "fault-test: no free DDS domain in 1..200" >&2
  exit 1
}

echo "fault-test: work directory $WORK; $KILLS kills, seed $SEED, $EVALS evaluations, DDS profile $MAPTUNE_DDS_PROFILE"
"$CLI" dataset generate --preset lab-tiny --runs 2 --submaps 5 --seed "$SEED" --out "$WORK/lab" >/dev/null 2>&1
cat >"$WORK/experiment.yaml" <<EOF
name: fault
space: $ROOT/configs/spaces/lru_matcher.yaml
dataset: $WORK/lab
view: complete
reference: gt
measure: {m_star: 8}
budget: {evaluations: $EVALS}
optimizer: {seed: $SEED, batch: 1}
start_points: [$ROOT/configs/params/x_baseline.yaml]
# Not the worker's defaults: the settings travel in every task (issue 12).
matcher: {settings: {icp_max_iterations: 10}}
EOF

T0=$SECONDS
lease_domain
launch_run reference "$DOMAIN"
wait_finished 1800
stop_all
REF_S=$((SECONDS - T0))
echo "fault-test: reference run finished in ${REF_S} s"

T1=$SECONDS
lease_domain
launch_run faults "$DOMAIN"
declare -A KILLED=([dataset_server]=0 [sample_db]=0 [worker]=0 [optimizer]=0)
SERVICES=(dataset_server sample_db worker optimizer)
done_kills=0
while [ "$done_kills" -lt "$KILLS" ] && ! optimizer_finished; do
  # 0 .. 3 s apart: often in the middle of a task, a reply or a file transfer.
  sleep "$(( (RANDOM % 28) / 10 )).$(( RANDOM % 10 ))"
  s=${SERVICES[$((RANDOM % 4))]}
  [ "$s" = optimizer ] && optimizer_finished && break
  kill -KILL "${PID[$s]}" 2>/dev/null || true
  wait "${PID[$s]}" 2>/dev/null || true
  echo "--- killed by fault-test (SIGKILL) at $((SECONDS - T1)) s" >>"$RUN_DIR/$s.log"
  KILLED[$s]=$((KILLED[$s] + 1))
  done_kills=$((done_kills + 1))
  start "$s"
done
# A run that makes no progress fails the test instead of hanging it.
wait_finished $((5 * REF_S + 300))
stop_all
FAULT_S=$((SECONDS - T1))
echo "fault-test: fault run finished in ${FAULT_S} s after $done_kills kills" \
     "(dataset_server ${KILLED[dataset_server]}, sample_db ${KILLED[sample_db]}, worker ${KILLED[worker]}, optimizer ${KILLED[optimizer]})"

# Compare: trials (what the optimizer was told, in order) and the stores (what was kept).
for r in reference faults; do
  "$CLI" trials --db "$WORK/$r/observations.db" -f csv --score-on "$WORK/lab" --m-star 8 >"$WORK/$r/store.csv"
done
status=0
python3 - "$WORK/reference" "$WORK/faults" <<'PY' || status=1
import csv, sys
ref, flt = sys.argv[1], sys.argv[2]
differences = []

def trials(d):
    with open(d + "/run/trials.csv") as f:
        rows = list(csv.DictReader(f))
    # What the model was told: the set, its score and failure; not timing or store hits.
    return [{k: v for k, v in r.items() if k not in ("from_store", "wall_s", "pair_s", "elapsed_s")} for r in rows]

def store(d):
    with open(d + "/store.csv") as f:
        rows = list(csv.DictReader(f))
    out = {}
    for r in rows:
        key = (r["dataset"], r["view"], r["matcher"]) + tuple(
            (k, r[k]) for k in sorted(r) if k not in ("id", "created", "dataset", "view", "matcher", "pairs",
                                                     "matched", "failed", "timeout", "wall_s", "p", "m", "eps", "v"))
        if key in out:
            differences.append(f"store {d}: observation stored twice: {key}")
        out[key] = {k: r[k] for k in ("pairs", "matched", "failed", "timeout", "p", "m", "eps", "v")}
    return out

a, b = trials(ref), trials(flt)
if len(a) != len(b):
    differences.append(f"trials: {len(a)} evaluations without faults, {len(b)} with")
for i, (x, y) in enumerate(zip(a, b)):
    if x != y:
        diff = {k: (x[k], y.get(k)) for k in x if x[k] != y.get(k)}
        differences.append(f"trials: evaluation {i + 1} differs: {diff}")
sa, sb = store(ref), store(flt)
for k in sorted(set(sa) | set(sb)):
    if k not in sb:
        differences.append(f"store: lost with faults: {k}")
    elif k not in sa:
        differences.append(f"store: only with faults: {k}")
    elif sa[k] != sb[k]:
        differences.append(f"store: {k}: {sa[k]} without faults, {sb[k]} with")
print(f"fault-test: {len(a)} vs {len(b)} evaluations, {len(sa)} vs {len(sb)} stored observations, "
      f"{len(differences)} differences")
for d in differences[:20]:
    print("  " + d)
sys.exit(1 if differences else 0)
PY
if [ "$done_kills" -lt "$KILLS" ]; then
  echo "fault-test: only $done_kills of $KILLS kills happened before the run finished (raise --evaluations)" >&2
  status=1
fi
echo "fault-test: $([ $status = 0 ] && echo PASS || echo FAIL) — reference ${REF_S} s, with faults ${FAULT_S} s"
exit $status
