#!/usr/bin/env bash
# The raster path's set-up (raster.json seconds.setup: the lookup pipelines a render compiles,
# its maps and buffers) for data/default's default technique, this build against another in
# alternating rounds on the same machine; medians and their ratio. The image is shrunk to
# 320x180 (set-up does not depend on it). Mesa's shader cache is off unless --warm-cache, so
# that each run compiles as a fresh CI machine does.
# Usage: bench/pipeline_setup.sh BASELINE_PENUMBRA [ROUNDS (5)] [--warm-cache] [-- raster options]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
base=${1:?usage: bench/pipeline_setup.sh BASELINE_PENUMBRA [ROUNDS] [--warm-cache] [-- raster options]}
rounds=${2:-5}
shift $(($# >= 2 ? 2 : 1))
cache_env=(MESA_SHADER_CACHE_DISABLE=true)
if [[ ${1:-} == --warm-cache ]]; then cache_env=(); shift; fi
[[ ${1:-} == -- ]] && shift
this=$root/build/app/penumbra
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 - "$root/data/default/scenario.json" "$work/s.json" "$root/data/default" <<'PY'
import json, os, sys
s = json.load(open(sys.argv[1]))
s["scene"] = os.path.join(sys.argv[3], s["scene"])
s["image"] = {"width": 320, "height": 180}
json.dump(s, open(sys.argv[2], "w"))
PY
for ((r = 0; r < rounds; ++r)); do
    for who in base this; do
        bin=$base
        [[ $who == this ]] && bin=$this
        env "${cache_env[@]}" "$bin" raster "$work/s.json" --out "$work/$who" "$@" >/dev/null
        python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['seconds']['setup'])" \
            "$work/$who/raster.json" >>"$work/$who.setup"
    done
done
python3 - "$work/base.setup" "$work/this.setup" <<'PY'
import statistics, sys
base, this = ([float(x) for x in open(p)] for p in sys.argv[1:3])
mb, mt = statistics.median(base), statistics.median(this)
print(f"set-up, median of {len(base)}: baseline {mb:.3f} s ({min(base):.3f}-{max(base):.3f}), "
      f"this {mt:.3f} s ({min(this):.3f}-{max(this):.3f}), ratio {mt / mb:.2f}")
PY
