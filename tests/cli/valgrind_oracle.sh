#!/usr/bin/env bash
# The oracle under Valgrind's memcheck: no undefined value may reach Embree or the outputs.
# Valgrind emulates no AVX-512, so Embree runs the kernels a CPU without it gets (docs/oracle.md
# section 7), which read every lane of a packet, active or not: this is where uninitialised
# lanes once aborted the oracle on AVX2 machines, and memcheck still sees them if the lanes
# are left undefined. data/default (three punctual
# lights) and data/soft (three area lights), at 96x54 and 64x36 pixels.
# Skipped (exit 77) when valgrind is not installed. Usage: valgrind_oracle.sh PENUMBRA SOURCE_DIR
set -uo pipefail
bin=$1 src=$2
# Optional outside CI (README); in CI (CI set) a missing valgrind is a failure, not a skip.
command -v valgrind >/dev/null || {
    [[ -n ${CI:-} ]] && { echo "FAIL: valgrind is not installed (CI must run this test; scripts/install-deps.sh installs it)"; exit 1; }
    echo "SKIP: valgrind is not installed (optional outside CI; scripts/install-deps.sh installs it)"
    exit 77
}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export PENUMBRA_CACHE_DIR=$tmp/cache
fail=0
for case in default:96:54 soft:64:36; do
    IFS=: read -r scene w h <<<"$case"
    sed "s#\"scene.glb\"#\"$src/data/default/scene.glb\"#; s#\"../default/scene.glb\"#\"$src/data/default/scene.glb\"#; \
         s/\"width\": 1280, \"height\": 720/\"width\": $w, \"height\": $h/" \
        "$src/data/$scene/scenario.json" >"$tmp/$scene.json"
    if valgrind -q --error-exitcode=9 "$bin" oracle "$tmp/$scene.json" --out "$tmp/$scene" --threads 2 -q \
        >"$tmp/$scene.log" 2>&1; then
        echo "ok: data/$scene oracle clean under memcheck"
    else
        echo "FAIL: data/$scene oracle under memcheck:"
        cat "$tmp/$scene.log"
        fail=1
    fi
done
exit $fail
