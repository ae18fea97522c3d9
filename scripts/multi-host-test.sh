#!/usr/bin/env bash
# Several hosts for real (issue 16): the services in separate network namespaces — one per
# "host", each with its own address on a bridge this script creates, and no loopback path
# between them — complete a tuning run with the real matcher, first with the multi-machine
# profile configs/dds/network_udp.xml (unicast discovery to the listed peers), then through a
# Fast DDS discovery server (its maptune_discovery_client profile). Everything it creates is
# torn down at exit. Needs root (or CAP_NET_ADMIN) for `ip netns`; exits 77 (ctest: skipped)
# with a message where namespaces cannot be made.
#
#   bash scripts/multi-host-test.sh [--build DIR] [--evaluations E] [--timeout S] [--keep]
#
# Hosts: h1 runs dataset_server and sample_db (and the discovery server), h2 a matcher worker,
# h3 the optimizer and a second worker. The workers fetch every submap from h1 over the bridge.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD=build/release EVALS=6 KEEP=0 TIMEOUT=300
while [ $# -gt 0 ]; do
  case "$1" in
    --build) BUILD=$2; shift 2 ;;
    --evaluations) EVALS=$2; shift 2 ;;
    --keep) KEEP=1; shift ;;
    --timeout) TIMEOUT=$2; shift 2 ;;
    -h|--help) sed -n 2,15p "$0"; exit 0 ;;
    *) echo "multi-host-test: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$EVALS$TIMEOUT" in ''|*[!0-9]*) echo "multi-host-test: --evaluations and --timeout take whole numbers" >&2; exit 2 ;; esac
BIN="$BUILD/services"
CLI="$BIN/maptune/maptune"
for b in "$CLI" "$BIN/maptune_dataset_server" "$BIN/maptune_sample_db" "$BIN/maptune_matcher_worker" "$BIN/maptune_optimizer"; do
  [ -x "$b" ] || { echo "multi-host-test: $b is missing: build first (cmake --build --preset release)" >&2; exit 2; }
done
command -v ip >/dev/null || { echo "multi-host-test: SKIP: no 'ip' command (iproute2)"; exit 77; }
command -v fast-discovery-server >/dev/null || { echo "multi-host-test: fast-discovery-server is missing (Debian package fastdds-tools)" >&2; exit 2; }

TAG="mh$$"                       # namespace and interface names of this run (interface names <= 15 chars)
SW="$TAG-sw"                     # the "switch": a namespace holding the bridge
HOSTS=("$TAG-h1" "$TAG-h2" "$TAG-h3")
NET="10.213.$(( $$ % 250 )).0"   # inside the namespaces only
ADDR=("${NET%.0}.1" "${NET%.0}.2" "${NET%.0}.3")
WORK=$(mktemp -d "${TMPDIR:-/tmp}/maptune-multihost-XXXXXX")
PIDS=()

stop_all() {  # SIGTERM (each service deletes its participant), SIGKILL after 5 s
  for p in "${PIDS[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${PIDS[@]}"; do
    for _ in $(seq 100); do kill -0 "$p" 2>/dev/null || break; sleep 0.05; done
    kill -KILL "$p" 2>/dev/null || true
    wait "$p" 2>/dev/null || true
  done
  PIDS=()
}
cleanup() {
  stop_all
  for ns in "${HOSTS[@]}" "$SW"; do ip netns del "$ns" 2>/dev/null || true; done
  if [ "$KEEP" = 1 ]; then echo "multi-host-test: work directory kept: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

if ! ip netns add "$SW" 2>"$WORK/netns.err"; then
  echo "multi-host-test: SKIP: cannot create network namespaces here ($(head -1 "$WORK/netns.err")); needs root or CAP_NET_ADMIN"
  exit 77
fi
ip -n "$SW" link add br0 type bridge
ip -n "$SW" link set br0 up
for i in 0 1 2; do
  h=${HOSTS[$i]}
  ip netns add "$h"
  ip link add "${TAG}a$i" type veth peer name "${TAG}b$i"
  ip link set "${TAG}a$i" netns "$h"
  ip link set "${TAG}b$i" netns "$SW"
  ip -n "$SW" link set "${TAG}b$i" master br0 up
  ip -n "$h" addr add "${ADDR[$i]}/24" dev "${TAG}a$i"
  ip -n "$h" link set "${TAG}a$i" up
  ip -n "$h" link set lo up
done
echo "multi-host-test: hosts ${HOSTS[*]} at ${ADDR[*]} on a bridge in $SW; work directory $WORK"

# One profile file per host from configs/dds/network_udp.xml: its own address whitelisted, the
# three hosts as initial peers, h1 as the discovery server.
profile_for() {  # profile_for INDEX FILE
  /usr/bin/env python3 - "$ROOT/configs/dds/network_udp.xml" "$2" "${ADDR[$1]}" "${ADDR[0]}" "${ADDR[@]}" <<'PY'
import sys, xml.etree.ElementTree as ET
src, dst, own, server, *peers = sys.argv[1:]
ns = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
ET.register_namespace("", ns)
q = lambda tag: "{%s}%s" % (ns, tag)
tree = ET.parse(src)
root = tree.getroot()
for wl in root.iter(q("interfaceWhiteList")):
    for a in list(wl): wl.remove(a)
    ET.SubElement(wl, q("address")).text = own
for lst in root.iter(q("initialPeersList")):
    for l in list(lst): lst.remove(l)
    for p in peers:
        ET.SubElement(ET.SubElement(ET.SubElement(lst, q("locator")), q("udpv4")), q("address")).text = p
for server_list in root.iter(q("discoveryServersList")):
    for a in server_list.iter(q("address")): a.text = server
for p in root.iter(q("participant")):  # the server listens on h1's address
    if p.get("profile_name") == "maptune_discovery_server":
        for a in p.iter(q("address")): a.text = server
tree.write(dst, xml_declaration=True, encoding="UTF-8")
PY
}
for i in 0 1 2; do profile_for "$i" "$WORK/h$((i + 1)).xml"; done

"$CLI" dataset generate --preset lab-tiny --runs 2 --submaps 4 --seed 5 --out "$WORK/lab" >/dev/null 2>&1
cat >"$WORK/experiment.yaml" <<EOF
name: multihost
space: $ROOT/configs/spaces/lru_matcher.yaml
dataset: $WORK/lab
view: complete
reference: gt
measure: {m_star: 6}
budget: {evaluations: $EVALS}
optimizer: {seed: 5, initial_points: 3}
start_points: [$ROOT/configs/params/x_baseline.yaml]
matcher: {threads: 1}
EOF

on() {  # on HOST_INDEX LOG CMD...: runs CMD in that host's namespace, in the background
  local i=$1 log=$2; shift 2
  ip netns exec "${HOSTS[$i]}" "$@" >"$log" 2>&1 &
  PIDS+=($!)
}

run_once() {  # run_once NAME PROFILE [DISCOVERY_SERVER]
  local name=$1 profile=$2 d=$(( (RANDOM % 200) + 1 )) dir="$WORK/$1"
  mkdir -p "$dir"
  local t0=$SECONDS
  PIDS=()
  if [ "${3:-}" = server ]; then
    # The server binary itself (the `fastdds discovery` wrapper would leave it running when killed).
    on 0 "$dir/discovery.log" fast-discovery-server -i 0 -x "maptune_discovery_server@$WORK/h1.xml"
  fi
  local dds="--domain $d --dds-profile $profile --dds-profiles"
  on 0 "$dir/dataset_server.log" "$BIN/maptune_dataset_server" --dataset "$WORK/lab" $dds "$WORK/h1.xml"
  on 0 "$dir/sample_db.log" "$BIN/maptune_sample_db" --db "$dir/observations.db" --cache "$dir/cache-db" $dds "$WORK/h1.xml"
  on 1 "$dir/worker_h2.log" "$BIN/maptune_matcher_worker" --id h2 --threads 1 --cache "$dir/cache-h2" $dds "$WORK/h2.xml"
  on 2 "$dir/worker_h3.log" "$BIN/maptune_matcher_worker" --id h3 --threads 1 --cache "$dir/cache-h3" $dds "$WORK/h3.xml"
  on 2 "$dir/optimizer.log" "$BIN/maptune_optimizer" --experiment "$WORK/experiment.yaml" --run-dir "$dir/run" \
     --wait 120 --cache "$dir/cache-opt" $dds "$WORK/h3.xml"
  local opt=${PIDS[-1]} status=0
  local end=$((SECONDS + TIMEOUT))
  while kill -0 "$opt" 2>/dev/null && [ $SECONDS -lt $end ]; do sleep 0.2; done
  if kill -0 "$opt" 2>/dev/null; then
    echo "multi-host-test: $name: the optimizer did not finish within $TIMEOUT s" >&2
    status=1
  else
    wait "$opt" || status=$?
  fi
  local rows=0
  [ -f "$dir/run/trials.csv" ] && rows=$(( $(wc -l <"$dir/run/trials.csv") - 1 ))
  local failed
  failed=$(awk -F, 'NR > 1 && $6 == 1' "$dir/run/trials.csv" 2>/dev/null | wc -l)
  stop_all
  # Both workers ran tasks, so submaps crossed the bridge from h1 to both other hosts.
  local tasks_h2 tasks_h3
  tasks_h2=$(grep -o 'stopping after [0-9]* tasks' "$dir/worker_h2.log" | grep -o '[0-9]*' || echo 0)
  tasks_h3=$(grep -o 'stopping after [0-9]* tasks' "$dir/worker_h3.log" | grep -o '[0-9]*' || echo 0)
  echo "multi-host-test: $name: $rows of $EVALS evaluations ($failed failed) in $((SECONDS - t0)) s;" \
       "tasks on h2 ${tasks_h2:-0}, on h3 ${tasks_h3:-0}; domain $d"
  if [ "$status" != 0 ] || [ "$rows" != "$EVALS" ] || [ "$failed" != 0 ] || [ "${tasks_h2:-0}" = 0 ] || [ "${tasks_h3:-0}" = 0 ]; then
    echo "multi-host-test: $name FAILED (optimizer exit $status); last lines of its logs:" >&2
    for f in "$dir"/*.log; do echo "== $f" >&2; tail -5 "$f" >&2; done
    return 1
  fi
}

run_once unicast maptune_network
run_once discovery_server maptune_discovery_client server
echo "multi-host-test: passed"
