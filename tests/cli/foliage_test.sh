#!/usr/bin/env bash
# A foliage-like scene of cut-outs made by scripts/make_foliage_scene.py (leaf cards, a chain-link
# fence through KHR_texture_transform, a grille faded by COLOR_0) validates, tunes and sweeps: the
# truth and the raster both let the light through the holes, so what is wrong lies at the leaves'
# edges (aliasing), not in the holes (false_shadow). Shadow volumes, which cannot draw cut-outs,
# are exit 2 naming a material, with nothing written.
# Usage: foliage_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"
python3 "$src/scripts/make_foliage_scene.py" "$tmp/scene" >/dev/null
sed -e 's/"width": 640/"width": 320/' -e 's/"height": 360/"height": 180/' "$tmp/scene/scenario.json" >"$tmp/scene/small.json"
rate() {  # rate REPORT LIGHT CLASS
    python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print(r["lights"][int(sys.argv[2])]["rates"][sys.argv[3]])' "$@"
}
below() { python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)' "$1" "$2"; }

run validate "$tmp/scene/scenario.json" --out "$tmp/v" -q
check "validate: exit 0" test "$rc" = 0
check "validate: report.json" test -s "$tmp/v/report.json"
for light in 0 1; do
    check "light $light: leaf-edge errors are aliasing" below 0.001 "$(rate "$tmp/v/report.json" $light aliasing)"
    check "light $light: no false_shadow in the holes" below "$(rate "$tmp/v/report.json" $light false_shadow)" 0.002
done
check "validate: the class map" test -s "$tmp/v/light0.classes.png"
check "validate: the cut-outs are said" grep -q '"cutouts"' "$tmp/v/report.json"

# Over a camera path: the session's moved camera keeps the cut-outs' buffers and set.
python3 - "$tmp/scene/small.json" "$tmp/scene/path.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
key = dict(s.pop("camera"))
s["camera_path"] = {"frames": 3, "keys": [key, dict(key, eye=[4.5, 3.5, 8.0])]}
json.dump(s, open(sys.argv[2], "w"))
PY
run validate "$tmp/scene/path.json" --out "$tmp/path" -q
check "camera path: exit 0" test "$rc" = 0
check "camera path: flicker.exr" test -s "$tmp/path/flicker.exr"
check "camera path: no false_shadow in the holes" below "$(rate "$tmp/path/report.json" 0 false_shadow)" 0.002

run tune "$tmp/scene/small.json" --out "$tmp/t" --set resolution=1024 --budget 6 -q
check "tune: exit 0" test "$rc" = 0
check "tune: technique.json" test -s "$tmp/t/technique.json"

run sweep "$tmp/scene/small.json" --out "$tmp/s" --vary resolution=512,1024 --vary filter.type=none,pcf -q
check "sweep: exit 0" test "$rc" = 0
check "sweep: four configurations" test "$(($(wc -l <"$tmp/s/sweep.csv") - 1))" = 4

# The midpoint's peel pass, caster offsets (babylon) and planar projection draw cut-outs too.
for preset in rtr-midpoint babylon rtr-planar; do
    run validate "$tmp/scene/small.json" --out "$tmp/$preset" --preset "$preset" -q
    check "$preset: exit 0" test "$rc" = 0
    check "$preset: no false_shadow in the holes" below "$(rate "$tmp/$preset/report.json" 0 false_shadow)" 0.002
done
for preset in rtr-shadow-volume; do
    run validate "$tmp/scene/small.json" --out "$tmp/no-$preset" --preset "$preset" -q
    check "$preset: exit 2" test "$rc" = 2
    check "$preset: names a cut-out material" grep -q 'cannot draw cut-outs (foliage.glb: materials\[[0-9]\] "' <<<"$err"
    check "$preset: nothing written" test ! -e "$tmp/no-$preset"
done
finish
