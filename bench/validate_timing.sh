#!/usr/bin/env bash
# Times `penumbra validate` with a cached oracle, the way a bias sweep or a second technique
# runs it: the bundled scene at 1280x720 with a 2048^2 map, once with its first (directional)
# light only and once with all three lights. Prints the median of N runs per phase, from
# report.json's timing. A measurement, not a test.
# Usage: bench/validate_timing.sh [RUNS=5]   (after scripts/build.sh; PENUMBRA_BIN=... times another build)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
runs=${1:-5}
bin="${PENUMBRA_BIN:-$root/build/app/penumbra}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export PENUMBRA_CACHE_DIR="$work/cache"
python3 - "$root" "$work" <<'PY'
import json, sys
root, work = sys.argv[1], sys.argv[2]
s = json.load(open(f"{root}/data/default/scenario.json"))
s["scene"] = f"{root}/data/default/scene.glb"
s["technique"] = {"resolution": 2048}
json.dump(s, open(f"{work}/three.json", "w"))
s["lights"] = s["lights"][:1]
json.dump(s, open(f"{work}/one.json", "w"))
PY
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
for scenario in one three; do
    "$bin" validate "$work/$scenario.json" --out "$work/warm" -q  # fills the cache
    for i in $(seq "$runs"); do
        "$bin" validate "$work/$scenario.json" --out "$work/run$i" -q
        cp "$work/run$i/report.json" "$work/$scenario-$i.json"
    done
    python3 - "$work" "$scenario" "$runs" <<'PY'
import json, statistics, sys
work, scenario, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
t = [json.load(open(f"{work}/{scenario}-{i}.json"))["timing"] for i in range(1, runs + 1)]
assert all(x["oracle_cached"] for x in t)
med = lambda f: statistics.median(f(x) for x in t)
lights = len(json.load(open(f"{work}/{scenario}-1.json"))["lights"])
raster, metrics = med(lambda x: x["raster_s"]), med(lambda x: x["metrics_s"])
print(f"{lights} light(s), 1280x720, 2048^2 map, cached oracle, median of {runs}: "
      f"oracle load {med(lambda x: x['oracle_s']):.3f} s, raster {raster:.3f} s "
      f"(GPU shadow {med(lambda x: x['raster_ms']['shadow']):.1f} ms, camera+lookup {med(lambda x: x['raster_ms']['camera']):.1f} ms), "
      f"metrics {metrics:.3f} s; raster + metrics {med(lambda x: x['raster_s'] + x['metrics_s']):.3f} s")
PY
done
