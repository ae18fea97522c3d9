#!/usr/bin/env bash
# The compose deployment (docker/compose.yaml) end to end with podman on Debian 12, no Docker
# engine and no registry: builds the base image with mmdebstrap and the maptune image, starts
# generate -> dataset_server, sample_db, 2 workers, optimizer on one bridge network, waits
# until the optimizer has used its budget, prints the best parameters from the `runs` volume,
# runs `maptune watch` once while the optimizer is still publishing (a late subscriber gets
# the current best at once), then stops and removes the containers and the network (images
# and volumes are kept; the run directory and the logs are also copied to runs/podman-demo/).
#
#   bash docker/run-podman.sh [--evaluations N] [--timeout SECONDS] [--keep-runs] [--secure] [--plugin]
#
#   --evaluations N  budget of the tuning run (default: the demo experiment's, 20)
#   --timeout S      give up when the optimizer has not finished after S seconds (default 3600)
#   --keep-runs      keep the `runs` volume of an earlier run: the optimizer resumes it and
#                    sample_db answers repeated parameter sets from its store (default: start
#                    from an empty `runs` volume, so the run really tunes)
#   --secure         DDS-Security on (docker/compose.secure.yaml, PKI in docker/pki made by
#                    scripts/make-pki.sh if missing); also checks that a `watch` without a
#                    certificate on the same network sees nothing
#   --plugin         compose profile `plugin`: also start the SDK plug-in matcher
#                    (maptune_fpfh_worker) and tune it (configs/experiments/fpfh_gicp_demo.yaml)
#                    instead of the reference matcher, whose workers keep running beside it
#
# Exits non-zero unless the run produced best_params.yaml.
set -euo pipefail

evaluations=""
timeout_s=3600
keep_runs=0
secure=0
plugin=0
while [ $# -gt 0 ]; do
  case "$1" in
    --evaluations) evaluations=$2; shift 2 ;;
    --timeout) timeout_s=$2; shift 2 ;;
    --keep-runs) keep_runs=1; shift ;;
    --secure) secure=1; shift ;;
    --plugin) plugin=1; shift ;;
    -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
    *) echo "run-podman: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$evaluations" in ''|[1-9]|[1-9][0-9]|[1-9][0-9][0-9]) ;; *) echo "run-podman: --evaluations expects 1..999" >&2; exit 2 ;; esac

# Rootful podman: the containers need a bridge network, and the script reads the volumes'
# host directories. Not root: run the whole script again under sudo.
if [ "$(id -u)" -ne 0 ]; then exec sudo bash "$0" "$@"; fi

cd "$(dirname "$0")/.."
repo=$PWD
project=maptune
compose=(podman-compose -p "$project" -f docker/compose.yaml)
if [ "$secure" -eq 1 ]; then
  compose+=(-f docker/compose.secure.yaml)
  [ -f docker/pki/ca.pem ] || bash scripts/make-pki.sh docker/pki
fi
started=$SECONDS
phase_start=$SECONDS
phase() { echo; echo "=== $(date +%T) $*"; phase_start=$SECONDS; }
took() { echo "--- $1 took $((SECONDS - phase_start)) s"; }

# --- packages -------------------------------------------------------------------------------
# podman-compose drives podman; runc is the runtime; catatonit is podman's init for
# `init: true`; the CNI plugins and iptables give the bridge network; mmdebstrap builds the
# base image without a registry.
phase "packages"
packages=(podman runc podman-compose catatonit containernetworking-plugins iptables mmdebstrap)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get -o DPkg::Lock::Timeout=600 update -q
  apt-get install -y -q --no-install-recommends -o DPkg::Lock::Timeout=600 "${missing[@]}"
else
  echo "all present: ${packages[*]}"
fi
# runc and modest ulimits for every podman call below (podman-compose's too), without
# touching /etc/containers: see the file.
export CONTAINERS_CONF=$repo/docker/podman-containers.conf
took packages

# --- images ---------------------------------------------------------------------------------
# nice: the build shares 2 cores with whatever else runs here.
phase "base image localhost/maptune-base:bookworm"
if podman image exists localhost/maptune-base:bookworm; then
  echo "present"
else
  nice -n 19 bash docker/make-base-image.sh
fi
took "base image"

# Always `build`: podman's layer cache makes it quick when nothing changed; any change in the
# work tree (the build context, docker/ included) recompiles: 4-7 min on 2 cores, ~10 min
# from scratch with the packages.
phase "image localhost/maptune:latest"
old_image=$(podman image inspect --format '{{.Id}}' localhost/maptune:latest 2>/dev/null || true)
nice -n 19 "${compose[@]}" build
# The image it replaces (3.8 GB, mostly shared layers) would stay as <none>: remove it.
if [ -n "$old_image" ] && [ "$old_image" != "$(podman image inspect --format '{{.Id}}' localhost/maptune:latest)" ]; then
  podman rmi "$old_image" >/dev/null 2>&1 || true
fi
took "image build"

# --- helpers --------------------------------------------------------------------------------
containers() { podman ps -a --format '{{.Names}}' --filter "label=io.podman.compose.project=$project"; }
state() { podman inspect --format '{{.State.Status}} {{.State.ExitCode}}' "$1" 2>/dev/null || echo "missing -1"; }
volume_dir() { podman volume inspect --format '{{.Mountpoint}}' "${project}_$1"; }
ensure_volume() {  # labelled as podman-compose labels the volumes it creates
  podman volume exists "${project}_$1" ||
    podman volume create --label "io.podman.compose.project=$project" \
      --label "com.docker.compose.project=$project" "${project}_$1" >/dev/null
}

# Down: SIGINT with the compose file's 20 s grace (podman-compose's `down` waits only 1 s),
# then `down` removes the containers; the network goes too, as with docker compose.
teardown() {
  local names
  names=$(containers)
  if [ -n "$names" ]; then
    # shellcheck disable=SC2086
    podman stop -t 20 $names >/dev/null || true
    podman ps -a --filter "label=io.podman.compose.project=$project" --format 'table {{.Names}}\t{{.Status}}'
    if [ -n "$logdir" ]; then  # keep the services' logs: the containers go now
      mkdir -p "$logdir"
      for n in $names; do podman logs "$n" > "$logdir/$n.log" 2>&1 || true; done
      echo "logs in $logdir/"
    fi
    "${compose[@]}" down >/dev/null 2>&1 || true
    # podman-compose only removes the containers it knows by name (not `run` ones).
    names=$(containers)
    # shellcheck disable=SC2086
    [ -z "$names" ] || podman rm -f $names >/dev/null || true
  fi
  if podman network exists "${project}_maptune"; then podman network rm "${project}_maptune" >/dev/null || true; fi
}
dump_logs() {
  local n
  for n in $(containers); do
    echo "----- logs of $n ($(state "$n"))"
    podman logs --tail 40 "$n" 2>&1 || true
  done
}

# --- start ----------------------------------------------------------------------------------
phase "up"
logdir=""
teardown  # leftovers of an interrupted run
out=runs/podman-demo  # a copy of the run directory and the logs, on the host
rm -rf "$out"
logdir=$out/logs
on_exit() {  # always down, also after a failure (with the logs first)
  local status=$?
  if [ "$status" -ne 0 ]; then dump_logs; fi
  phase "down"
  teardown
  took down
  exit "$status"
}
trap on_exit EXIT
trap 'exit 130' INT TERM  # so that Ctrl-C also brings everything down
if [ "$keep_runs" -eq 0 ] && podman volume exists "${project}_runs"; then
  podman volume rm "${project}_runs" >/dev/null
  echo "emptied the runs volume (--keep-runs keeps it)"
fi
ensure_volume runs
ensure_volume datasets
runs=$(volume_dir runs)

experiment=configs/experiments/demo.yaml
extra_services=()
if [ "$plugin" -eq 1 ]; then
  experiment=configs/experiments/fpfh_gicp_demo.yaml
  extra_services=(fpfh_worker)
  export MAPTUNE_EXPERIMENT=$experiment
  echo "plug-in: maptune_fpfh_worker joins the reference workers; tuning $experiment"
fi
# A smaller budget: a copy of the experiment in the runs volume, its relative paths made
# absolute (they are relative to the file's directory, configs/experiments/ in the image).
if [ -n "$evaluations" ]; then
  podman run --rm -v "${project}_runs:/runs" localhost/maptune:latest sh -c \
    "sed -e 's|^budget:.*|budget: {evaluations: $evaluations}|' -e 's|\\.\\./\\.\\./|/opt/maptune/|g' \
         -e 's|\\.\\./|/opt/maptune/configs/|g' $experiment > /runs/demo_experiment.yaml"
  export MAPTUNE_EXPERIMENT=/runs/demo_experiment.yaml
  echo "budget: $evaluations evaluations ($MAPTUNE_EXPERIMENT)"
fi

# podman-compose 1.0.3 starts services in dependency order but ignores depends_on conditions
# and profiles: so generate runs to completion first, and `up` names the services to start
# (leaving out `watch`, profile tools, and `fpfh_worker`, profile plugin, unless --plugin).
# It honours deploy.replicas (2 workers).
"${compose[@]}" up -d --no-build generate
if ! timeout 600 podman wait maptune_generate_1 >/dev/null || [ "$(state maptune_generate_1)" != "exited 0" ]; then
  echo "run-podman: generate failed ($(state maptune_generate_1))" >&2
  exit 1
fi
podman logs maptune_generate_1
podman rm maptune_generate_1 >/dev/null  # `up` below runs it again: a no-op, the dataset is there
"${compose[@]}" up -d --no-build dataset_server sample_db worker "${extra_services[@]}" optimizer
podman ps --filter "label=io.podman.compose.project=$project" --format 'table {{.Names}}\t{{.Status}}\t{{.Command}}'
took up

# --- tuning ---------------------------------------------------------------------------------
phase "tuning (timeout ${timeout_s} s)"
services=(maptune_dataset_server_1 maptune_sample_db_1 maptune_worker_1 maptune_worker_2)
[ "$plugin" -eq 0 ] || services+=(maptune_fpfh_worker_1)
trials=$runs/demo/trials.csv
watched=0
watch_out=""
deadline=$((SECONDS + timeout_s))
last=-1
while :; do
  opt_state=$(state maptune_optimizer_1)
  case "$opt_state" in running*|created*|configured*|initialized*) ;; *) break ;; esac
  for s in "${services[@]}"; do
    if [ "$(state "$s" | cut -d' ' -f1)" != running ]; then
      echo "run-podman: $s is not running ($(state "$s")) while the optimizer is" >&2
      exit 1
    fi
  done
  done_n=0
  [ -f "$trials" ] && done_n=$(($(wc -l < "$trials") - 1))
  if [ "$done_n" -ne "$last" ]; then
    echo "$(date +%T) $done_n evaluations done"
    last=$done_n
  fi
  # A late subscriber: once there is a best, `watch` (profile tools) must print it at once.
  # Done while the optimizer runs: its latched BestSoFar lives as long as its writer.
  if [ "$watched" -eq 0 ] && [ "$done_n" -ge 1 ]; then
    watched=1
    echo "$(date +%T) maptune watch --once (compose service watch):"
    if watch_out=$("${compose[@]}" run --rm --no-deps -T watch maptune watch --once --timeout 60 </dev/null 2>&1); then
      watch_ok=1
    else
      watch_ok=0
    fi
    # podman-compose echoes its podman command lines; the rest is maptune watch's output.
    # With two compose files it also prints the merged configuration (" ** merged:" and JSON).
    watch_out=$(printf '%s\n' "$watch_out" | awk '/\*\* merged:/ { skip = 1; next } skip && /^}$/ { skip = 0; next } !skip' |
                grep -v -e '^podman ' -e '^exit code:' -e "^\['podman'" -e '^using podman' || true)
    printf '%s\n' "$watch_out" | sed 's/^/    watch| /'
    [ "$watch_ok" -eq 1 ] || echo "run-podman: watch printed no update within 60 s" >&2
    if [ "$secure" -eq 1 ]; then
      # The same watch on the same network without a certificate (no MAPTUNE_DDS_SECURITY, no
      # PKI mounted) must see nothing.
      echo "$(date +%T) maptune watch --once without a certificate (expected: no update):"
      if podman run --rm --network "${project}_maptune" -e MAPTUNE_DOMAIN=42 localhost/maptune:latest \
          maptune watch --once --timeout 20 </dev/null >/dev/null 2>&1; then
        echo "run-podman: a watch without a certificate received the best" >&2
        exit 1
      fi
      echo "    no update in 20 s: refused"
    fi
  fi
  if [ "$SECONDS" -ge "$deadline" ]; then
    echo "run-podman: the optimizer has not finished after ${timeout_s} s" >&2
    exit 1
  fi
  sleep 2  # poll interval: short budgets finish within seconds
done
echo "optimizer: $opt_state (status, exit code)"
if [ "$watched" -eq 0 ]; then
  # e.g. --keep-runs with the budget already used: the optimizer resumes, publishes no new
  # best and exits at once, so there is no live publisher for a late subscriber.
  echo "watch: not run, the optimizer finished before the first poll saw an evaluation"
fi
echo "----- optimizer log (last lines)"
podman logs --tail 25 maptune_optimizer_1 2>&1
took tuning

# --- results --------------------------------------------------------------------------------
phase "results in the runs volume ($runs/demo)"
if [ ! -s "$runs/demo/best_params.yaml" ]; then
  echo "run-podman: no best_params.yaml in the runs volume" >&2
  exit 1
fi
cat "$runs/demo/best_params.yaml"
echo "trials.csv: $(wc -l < "$trials") lines (header + evaluations)"
# trials.csv columns by name (evaluation, p, failed, origin, ...).
awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i; next }
         $c["origin"] == "start" && !b { printf "baseline p = %s (evaluation %s, the start point)\n", $c["p"], $1; b = 1 }
         $c["failed"] == 0 && (best == "" || $c["p"] + 0 > best + 0) { best = $c["p"]; e = $1 }
         END { if (best != "") printf "best p     = %s (evaluation %s)\n", best, e }' "$trials"
[ -n "$watch_out" ] && { echo "watch (late subscriber):"; printf '%s\n' "$watch_out" | sed 's/^/    /'; }
mkdir -p "$out"
cp -r "$runs/demo/." "$out/"
echo "copied to $out/"
took results
if [ "$opt_state" != "exited 0" ]; then
  echo "run-podman: the optimizer exited with ${opt_state#* }" >&2
  exit 1
fi
echo "run-podman: done in $((SECONDS - started)) s"
