#!/usr/bin/env bash
# Installs the Debian packages penumbra needs (if missing) and builds it in build/ (Release,
# warnings as errors). Usage: scripts/build.sh [extra cmake args]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPENUMBRA_WERROR=ON "$@" >/dev/null
ninja -C "$root/build"
