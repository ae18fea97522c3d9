#!/usr/bin/env bash
# Installs every Debian 12 package maptune needs to build, test and run, and the report
# renderer's npm packages (tools/report, pinned by its package-lock.json).
# --test adds what only the tests need (Chromium, which opens the generated report; clang and
# libFuzzer for the fuzz harnesses).
# --no-report-renderer skips Node.js and the renderer's npm packages (the service image:
# services write no reports; `maptune report` runs where Node.js is).
# Idempotent: packages already present are skipped, so a second run costs a few dpkg queries.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake pkg-config git ca-certificates openssl python3
  libeigen3-dev libsuitesparse-dev liblbfgspp-dev
  libyaml-cpp-dev libcli11-dev libspdlog-dev nlohmann-json3-dev
  libsqlite3-dev libprotobuf-dev protobuf-compiler
  libgtest-dev libgmock-dev libbenchmark-dev
  libpcl-dev liboctomap-dev
  libfastrtps-dev fastddsgen fastdds-tools
  cyclonedds-dev cyclonedds-tools
  docker-compose
)
# Node.js renders reports; a machine that has it from elsewhere keeps its own.
renderer=1
for arg in "$@"; do
  case "$arg" in
    --test) packages+=(chromium clang libfuzzer-14-dev) ;;
    --no-report-renderer) renderer=0 ;;
    *) echo "install-deps: unknown argument '$arg' (--test, --no-report-renderer)" >&2; exit 2 ;;
  esac
done
if [ "$renderer" = 1 ] && { ! command -v node >/dev/null || ! command -v npm >/dev/null; }; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
else
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  echo "install-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends -o DPkg::Lock::Timeout=600 "${missing[@]}"
fi

# The report renderer's packages, exactly as locked; again only when the lock changed.
stamp=tools/report/node_modules/.maptune-lock
if [ "$renderer" = 1 ] && ! cmp -s tools/report/package-lock.json "$stamp" 2>/dev/null; then
  echo "install-deps: npm ci in tools/report"
  (cd tools/report && npm ci --no-audit --no-fund --loglevel=error)
  cp tools/report/package-lock.json "$stamp"
fi
