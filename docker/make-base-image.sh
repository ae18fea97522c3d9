#!/usr/bin/env bash
# Builds the Debian 12 base image locally (no registry pull) and imports it into podman as
# localhost/maptune-base:bookworm. Needs mmdebstrap and podman (scripts/install-deps.sh does
# not install them: only docker/run-podman.sh needs them).
set -euo pipefail
tar_file=$(mktemp --suffix=.tar)
trap 'rm -f "$tar_file"' EXIT
mmdebstrap --variant=apt --include=ca-certificates bookworm "$tar_file"
podman import --change 'CMD ["/bin/bash"]' "$tar_file" localhost/maptune-base:bookworm
