#!/usr/bin/env bash
# Issue #37's writing goal: validate's own `writing` figure as a share of the run, on the bundled
# scene (data/default, 1280x720, 3 lights, cached oracle), from the line validate prints:
#   validate: ... oracle from cache (T s), Vulkan device T s, raster T s, metrics T s, writing T s
# The share is writing / (oracle + device + raster + metrics + writing). With BASELINE, that
# build runs alternately in the same rounds (this machine is shared: compare within a round).
# A measurement, not a test.
# Usage: bench/validate_writing.sh [RUNS=5] [BASELINE_PENUMBRA] [-- VALIDATE_OPTIONS...]
#        (PENUMBRA_BIN=... times another build than build/app/penumbra)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
runs=${1:-5}
baseline=${2:-}
shift $(($# < 2 ? $# : 2))
[[ ${1:-} == -- ]] && shift
bin="${PENUMBRA_BIN:-$root/build/app/penumbra}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export PENUMBRA_CACHE_DIR="$work/cache"
bins=("$bin")
[[ -n $baseline ]] && bins+=("$baseline")
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); load $(cut -d' ' -f1-3 /proc/loadavg)"
for b in "${bins[@]}"; do "$b" validate "$root/data/default/scenario.json" --out "$work/warm" -q "$@"; done  # the cache
for i in $(seq "$runs"); do
    for k in "${!bins[@]}"; do
        rm -rf "$work/out"
        "${bins[$k]}" validate "$root/data/default/scenario.json" --out "$work/out" "$@" | grep '^validate:' >>"$work/times.$k"
    done
done
python3 - "$work" "${bins[@]}" <<'PY'
import re, statistics, sys
work, bins = sys.argv[1], sys.argv[2:]
pat = re.compile(r"oracle from cache \(([\d.]+) s\), Vulkan device ([\d.]+) s, raster ([\d.]+) s, "
                 r"metrics ([\d.]+) s, writing ([\d.]+) s")
for k, b in enumerate(bins):
    rows = []
    for line in open(f"{work}/times.{k}"):
        m = pat.search(line)
        if not m:
            sys.exit(f"validate_writing: not a cached run: {line.strip()}")
        rows.append([float(x) for x in m.groups()])
    share = [r[4] / sum(r) for r in rows]
    med = lambda j: statistics.median(r[j] for r in rows)
    print(f"{b}: {len(rows)} runs, medians: oracle {med(0):.3f} s, device {med(1):.3f} s, raster {med(2):.3f} s, "
          f"metrics {med(3):.3f} s, writing {med(4):.3f} s; writing's share {statistics.median(share):.1%} "
          f"(runs {min(share):.1%}-{max(share):.1%})")
PY
