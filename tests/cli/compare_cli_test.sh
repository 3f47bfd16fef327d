#!/usr/bin/env bash
# `penumbra camera` and `penumbra compare` end to end: the capture kit's JSON, penumbra's own
# raster frame scored as an engine's, exit codes and messages for bad frames, no partial output.
# Usage: compare_cli_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 "$tmp/stderr"))"; }
export PENUMBRA_CACHE_DIR=$tmp/cache
sed "s#\"scene.glb\"#\"$src/data/default/scene.glb\"#; s/\"width\": 1280, \"height\": 720/\"width\": 160, \"height\": 90/" \
    "$src/data/default/scenario.json" >"$tmp/small.json"
sed 's/"width": 160, "height": 90/"width": 80, "height": 90/' "$tmp/small.json" >"$tmp/narrow.json"

# The capture kit: JSON with matrices in each convention.
for conv in gl vulkan d3d; do
    run camera "$tmp/small.json" --convention $conv
    check "camera --convention $conv exits 0" test "$rc" -eq 0
    check "camera --convention $conv prints its conventions" python3 - "$tmp/stdout" $conv <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); conv = sys.argv[2]
assert j["image"] == {"width": 160, "height": 90}
assert j["ndc_depth_range"] == ([-1, 1] if conv == "gl" else [0, 1])
assert j["ndc_y"] == ("down" if conv == "vulkan" else "up")
assert len(j["view_array"]) == 16 and len(j["projection_array"]) == 16 and len(j["lights"]) == 3
# The eye maps to the view-space origin, and the target (on the view axis) to NDC (0, 0).
V, P = j["view"], j["projection"]
mul = lambda M, v: [sum(M[r][c] * v[c] for c in range(4)) for r in range(4)]
assert max(abs(x) for x in mul(V, j["camera"]["eye"] + [1])[:3]) < 1e-9
clip = mul(P, mul(V, j["camera"]["target"] + [1]))
assert abs(clip[0] / clip[3]) < 1e-9 and abs(clip[1] / clip[3]) < 1e-9
assert j["lights"][1]["type"] == "spot" and abs(j["lights"][1]["gltf"]["spot"]["outerConeAngle"] - 0.6981317) < 1e-6
PY
done
run camera "$tmp/small.json" --convention metal
check "an unknown convention exits 2" test "$rc" -eq 2

# penumbra's raster frame as an engine's: named channels light<i>.V; depth from the oracle.
run raster "$tmp/small.json" --out "$tmp/r" -q
run oracle "$tmp/small.json" --out "$tmp/o" -q
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --out "$tmp/c" -q
check "compare exits 0" test "$rc" -eq 0
for f in report.json report.html errors.exr engine.json oracle.json light0.classes.png light2.compare.png; do
    check "compare writes $f" test -s "$tmp/c/$f"
done
check "without depth the report says a silhouette band is left out" python3 -c "
import json; r = json.load(open('$tmp/c/report.json'))
assert r['coverage']['source'] == 'silhouette_band' and 'left out' in r['coverage']['note']
assert all(l['evidence']['source'] == 'oracle_geometry' for l in r['lights'])
assert r['technique']['engine']['channels'][2]['channel'] == 'light2.V'"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --depth "$tmp/o/oracle.exr" --depth-space linear \
    --light 1 --texel-m 0.02 --out "$tmp/c1" -q
check "compare --depth --light 1 exits 0" test "$rc" -eq 0
check "with depth, coverage comes from it; one light; the footprint given" python3 -c "
import json; r = json.load(open('$tmp/c1/report.json'))
assert r['coverage']['source'] == 'depth' and r['coverage']['mismatch_fraction'] < 0.01, r['coverage']
assert len(r['lights']) == 1 and r['lights'][0]['type'] == 'spot'
assert r['lights'][0]['evidence']['texel_footprint'] == 'given'"

# A gate: exit 1, one line per failure, JUnit written.
echo '{"checks": [{"metric": "pixels.scored", "min": 1e9}]}' >"$tmp/gate.json"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --out "$tmp/g" --gate "$tmp/gate.json" --junit "$tmp/g.xml" -q
check "a failing gate exits 1" test "$rc" -eq 1
check "the failure is named" grep -q "light 0: pixels.scored" <<<"$err"
check "JUnit written" grep -q "<failure" "$tmp/g.xml"

# Bad frames: exit 2, the file and what was expected named, no output folder.
run raster "$tmp/narrow.json" --out "$tmp/rn" -q
run compare "$tmp/small.json" --image "$tmp/rn/raster.exr" --out "$tmp/x1"
check "wrong size exits 2" test "$rc" -eq 2
check "wrong size message" grep -q "rn/raster.exr: 80x90 pixels; expected the scenario's image size, 160x90" <<<"$err"
check "wrong size writes nothing" test ! -e "$tmp/x1"
# A two-light scenario: its raster.exr lacks light2.V; an RGB image for two lights is ambiguous.
python3 -c "
import json, sys; j = json.load(open('$tmp/small.json')); j['lights'] = j['lights'][:2]
json.dump(j, open('$tmp/two.json', 'w'))"
run raster "$tmp/two.json" --out "$tmp/r2" -q
run compare "$tmp/small.json" --image "$tmp/r2/raster.exr" --out "$tmp/x2"
check "a missing channel exits 2" test "$rc" -eq 2
check "missing channel message" grep -q "r2/raster.exr: no channel light2.V (it has A, prim, light0.V, .*light1.V.*); expected one for light 2" <<<"$err"
run compare "$tmp/two.json" --image "$tmp/o/oracle.png" --out "$tmp/x6"
check "an RGB image for two lights exits 2" test "$rc" -eq 2
check "channels message" grep -q "oracle.png: channels R, G, B; expected light<i>.V channels or one channel per light (2)" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --depth "$tmp/o/oracle.exr" --out "$tmp/x3"
check "--depth without --depth-space exits 2" test "$rc" -eq 2
check "depth-space message" grep -q "oracle.exr: --depth needs --depth-space" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --light 3 --out "$tmp/x4"
check "--light out of range exits 2" test "$rc" -eq 2
check "--light message" grep -q -- "--light 3: small.json has 3 lights" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/nothing.exr" --out "$tmp/x5"
check "a missing image exits 2" test "$rc" -eq 2
check "missing image message" grep -q "nothing.exr: no such image file" <<<"$err"
check "no output folders from bad runs" test ! -e "$tmp/x2" -a ! -e "$tmp/x3" -a ! -e "$tmp/x4" -a ! -e "$tmp/x5" -a ! -e "$tmp/x6"
finish
