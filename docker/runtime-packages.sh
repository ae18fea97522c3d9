#!/usr/bin/env bash
# The Debian packages that provide the shared libraries the given executables load (ldd), one
# per line: what the runtime stage of docker/Dockerfile installs instead of the toolchain.
#
#   bash docker/runtime-packages.sh EXECUTABLE...
set -euo pipefail
[ $# -gt 0 ] || { echo "usage: runtime-packages.sh EXECUTABLE..." >&2; exit 2; }
missing=$(ldd "$@" | grep 'not found' || true)
if [ -n "$missing" ]; then echo "runtime-packages: unresolved libraries: $missing" >&2; exit 1; fi
ldd "$@" | awk '$2 == "=>" && $3 ~ /^\// { print $3 }' | sort -u | while read -r lib; do
  # Merged /usr: dpkg may have registered the file under /lib or /usr/lib.
  real=$(readlink -f "$lib")
  pkg=$(dpkg -S "$real" 2>/dev/null || dpkg -S "$lib" 2>/dev/null || dpkg -S "*/$(basename "$lib")" 2>/dev/null || true)
  if [ -z "$pkg" ]; then echo "runtime-packages: no package owns $lib" >&2; exit 1; fi
  printf '%s\n' "$pkg" | head -n1 | cut -d: -f1
done | sort -u
