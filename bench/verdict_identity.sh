#!/usr/bin/env bash
# Verdicts of two builds, compared byte for byte (docs/testing.md, "Verdicts unchanged"): every
# configuration below is validated by both (data/default and data/soft, one or more techniques
# per family), and report.json's lights, errors.exr and every PNG must be equal. Timings and
# paths are not verdicts and are not compared.
# Usage: bench/verdict_identity.sh BASELINE_PENUMBRA [THIS_PENUMBRA] [--size WxH]
# (default THIS: build/app/penumbra; --size shrinks the scenarios' image, e.g. 320x180).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
base=${1:?usage: bench/verdict_identity.sh BASELINE_PENUMBRA [THIS_PENUMBRA] [--size WxH]}
shift
this=$root/build/app/penumbra
if [[ $# -gt 0 && $1 != --size ]]; then this=$1; shift; fi
size=""
if [[ $# -gt 1 && $1 == --size ]]; then size=$2; fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for scene in default soft; do
    python3 - "$root/data/$scene/scenario.json" "$work/$scene.json" "$size" "$root/data/$scene" <<'PY'
import json, os, sys
src, dst, size, folder = sys.argv[1:5]
s = json.load(open(src))
s["scene"] = os.path.join(folder, s["scene"])
if size:
    w, h = size.split("x")
    s["image"] = {"width": int(w), "height": int(h)}
json.dump(s, open(dst, "w"))
PY
done
configs=(
    "default|"
    "default|--preset three"
    "default|--preset unity-urp"
    "default|--preset filament"
    "default|--preset bevy"
    "default|--preset godot"
    "default|--preset three-csm"
    "default|--set family=cascaded --set cascades.sdsm=true --set cascades.texel_scaled_bias=true --set cascades.overlap=0.2 --set cascades.max_distance=40"
    "default|--set filter.type=none --set family=vsm --set blur=2 --set mipmaps=true"
    "default|--set filter.type=none --set family=esm"
    "default|--set filter.type=none --set family=evsm2"
    "default|--set filter.type=none --set family=evsm4 --set blur=1"
    "default|--set filter.type=none --set family=msm --set msm.storage=16"
    "default|--preset rtr-midpoint"
    "default|--set depth_layer=second"
    "default|--preset rtr-shadow-volume"
    "default|--preset rtr-planar"
    "default|--set precision=world_float32 --set reversed_z=true"
    "soft|"
    "soft|--preset averaged-hard-shadows"
)
failed=0
for c in "${configs[@]}"; do
    scene=${c%%|*}
    args=${c#*|}
    for who in base this; do
        bin=$base
        [[ $who == this ]] && bin=$this
        # shellcheck disable=SC2086
        "$bin" validate "$work/$scene.json" --out "$work/$who" --errors -q --cache "$work/cache" $args >"$work/$who.log" 2>&1 || {
            rc=$?
            [[ $rc == 1 ]] || { echo "FAIL [$scene $args] $who exit $rc:"; tail -5 "$work/$who.log"; failed=1; continue 2; }
        }
    done
    same=1
    python3 - "$work/base/report.json" "$work/this/report.json" <<'PY' || same=0
import json, sys
a, b = (json.load(open(p))["lights"] for p in sys.argv[1:3])
sys.exit(0 if a == b else 1)
PY
    for f in "$work"/base/*.png "$work"/base/errors.exr; do
        cmp -s "$f" "$work/this/$(basename "$f")" || { same=0; echo "  differs: $(basename "$f")"; }
    done
    if [[ $same == 1 ]]; then echo "same [$scene $args]"; else echo "DIFFERENT [$scene $args]"; failed=1; fi
    rm -rf "$work/base" "$work/this"
done
exit $failed
