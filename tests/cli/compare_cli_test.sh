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
# Issue 32: options checked before any work, exit 2 naming the option, nothing written.
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --texel-m 1e39 --out "$tmp/y1"
check "--texel-m 1e39 (beyond float) exits 2" test "$rc" -eq 2
check "--texel-m 1e39 is named" grep -q -- "--texel-m: 1e39 is not in \[1e-12, 1e+15\]" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --texel-m 0 --out "$tmp/y1"
check "--texel-m 0 exits 2" test "$rc" -eq 2
check "--texel-m 0's range is readable" test "${#err}" -lt 200
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --bias-m nan --out "$tmp/y1"
check "--bias-m nan exits 2" test "$rc" -eq 2
bad=$'caf\xe9'
# Paths are any bytes (as hostile_input.sh row 6 has them for validate): a Latin-1 name works,
# and is shown escaped (\xNN) wherever a report or the capture kit's JSON holds it. Names are
# refused (exit 2, before any work).
cp "$tmp/r/raster.exr" "$tmp/$bad.exr"
cp "$tmp/o/oracle.exr" "$tmp/$bad.depth.exr"
cp "$tmp/small.json" "$tmp/$bad.json"
echo '{"checks": [{"metric": "rates.acne", "max": 1}]}' >"$tmp/$bad.gate.json"
run compare "$tmp/$bad.json" --image "$tmp/$bad.exr" --depth "$tmp/$bad.depth.exr" --depth-space linear \
    --gate "$tmp/$bad.gate.json" --junit "$tmp/$bad.xml" --cache "$tmp/cache-$bad" --out "$tmp/ok-$bad" -q
check "Latin-1 paths for every compare option exit 0" test "$rc" -eq 0
check "Latin-1 paths: report.json names the files escaped" python3 - "$tmp/ok-$bad/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1].encode("utf-8", "surrogateescape")))
assert r["engine"]["image"].endswith("caf\\xE9.exr") and r["engine"]["depth_file"].endswith("caf\\xE9.depth.exr"), r["engine"]
PY
check "Latin-1 paths: the JUnit file is written" test -s "$tmp/$bad.xml"
run camera "$tmp/$bad.json"
check "camera: a Latin-1 scenario path exits 0" test "$rc" -eq 0
check "camera: the scenario is named escaped" grep -q '"scenario": ".*caf\\\\xE9.json"' "$tmp/stdout"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --out "$tmp/y2" --max-memory $'8\xe9G'
check "a non-UTF-8 name (--max-memory) exits 2" test "$rc" -eq 2
check "a non-UTF-8 name is named" grep -q -- "--max-memory: .*8\\\\xE9G.* is not valid UTF-8" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --out ""
check "--out \"\" exits 2" test "$rc" -eq 2
check "--out \"\" says the option and that it is empty" grep -q -- "--out: empty" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --depth-space ndc --out "$tmp/y3"
check "--depth-space without --depth exits 2" test "$rc" -eq 2
check "--depth-space without --depth is named" grep -q -- "--depth-space ndc without --depth" <<<"$err"
check "no output from option errors" test ! -e "$tmp/y1" -a ! -e "$tmp/y2" -a ! -e "$tmp/y3"

# What is not an image file is named for what it is.
mkfifo "$tmp/fifo"
for what in "$tmp/r:a folder" "$tmp/fifo:a FIFO (named pipe)" "/dev/zero:a device"; do
    run compare "$tmp/small.json" --image "${what%%:*}" --out "$tmp/y4"
    check "${what#*:} as --image exits 2" test "$rc" -eq 2
    check "${what#*:} as --image is named" grep -q -- "${what%%:*}: ${what#*:}, not an image file" <<<"$err"
done
# A 74-byte PNG that declares 20000x20000 pixels: refused from its header, not decoded (4.8 GB).
python3 - "$tmp/huge.png" <<'PY'
import struct, sys, zlib
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
ihdr = struct.pack(">IIBBBBB", 20000, 20000, 8, 0, 0, 0, 0)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) +
                              chunk(b"IEND", b""))
PY
for opt in --image --depth; do
    args=(--image "$tmp/huge.png")
    [ $opt = --depth ] && args=(--image "$tmp/r/raster.exr" --depth "$tmp/huge.png" --depth-space linear)
    rc=$( (ulimit -v 3000000; timeout 60 "$bin" compare "$tmp/small.json" "${args[@]}" --out "$tmp/y4" \
        >"$tmp/stdout" 2>"$tmp/stderr"); echo $?)
    err=$(cat "$tmp/stderr")
    check "a PNG declaring 20000x20000 as $opt exits 2 (in 3 GB)" test "$rc" -eq 2
    check "its size is named" grep -q "huge.png: 20000x20000 pixels; expected the scenario's image size, 160x90" <<<"$err"
done
check "no output from bad files" test ! -e "$tmp/y4"

# A depth buffer that shows no surface (all zeros; linear depth read as ndc) scores nothing:
# exit 2 naming why, not a passed gate.
python3 - "$tmp/zeros.pfm" "$tmp/o/oracle.exr" <<'PY'
import struct, sys
w, h = 160, 90
open(sys.argv[1], "wb").write(b"Pf\n%d %d\n-1.0\n" % (w, h) + struct.pack("<%df" % (w * h), *([0.0] * (w * h))))
PY
echo '{"checks": [{"metric": "rates.acne", "max": 1}]}' >"$tmp/loose.json"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --depth "$tmp/zeros.pfm" --depth-space linear \
    --gate "$tmp/loose.json" --out "$tmp/y5"
check "an all-zero depth exits 2" test "$rc" -eq 2
check "an all-zero depth is named, and why" grep -q "zeros.pfm: only 0.00% of the .* surface pixels .* is --depth-space right" <<<"$err"
run compare "$tmp/small.json" --image "$tmp/r/raster.exr" --depth "$tmp/c1/../o/oracle.exr" --depth-space ndc \
    --out "$tmp/y5"
check "linear depth read as ndc exits 2" test "$rc" -eq 2
check "no output from a frame that scores nothing" test ! -e "$tmp/y5"

# An infinite far plane (no zfar): camera prints a projection, not null; compare reads ndc depth
# written through it (w = 1 - n / z) and scores the surface.
python3 -c "
import json; j = json.load(open('$tmp/small.json')); del j['camera']['zfar']
json.dump(j, open('$tmp/inf.json', 'w'))"
run camera "$tmp/inf.json" --convention vulkan
check "camera without zfar exits 0" test "$rc" -eq 0
check "camera without zfar prints the infinite-far projection" python3 - "$tmp/stdout" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); c = j["camera"]
assert "null" not in open(sys.argv[1]).read()
assert c["infinite_far"] is True and "zfar" not in c, c
n = c["znear"]; P = j["projection"]
assert P[2][2] == -1 and abs(P[2][3] + n) < 1e-12 and P[3][2] == -1, P
PY
# (compare on ndc depth through this projection: tests/compare, NdcDepthFromAnInfiniteFarProjectionIsScored.)

# Warnings as every command gives them; results on stdout that cannot be written are an error.
python3 -c "
import json; j = json.load(open('$tmp/small.json')); j['lights'] = []
json.dump(j, open('$tmp/dark.json', 'w'))"
run camera "$tmp/dark.json"
check "camera on a scenario without lights exits 0" test "$rc" -eq 0
check "camera warns of no lights" grep -q "warning: dark.json: the scenario has no lights" <<<"$err"
for cmd in "camera $tmp/small.json" "--version" "camera --help"; do
    $bin $cmd >/dev/full 2>"$tmp/stderr"
    rc=$?
    err=$(cat "$tmp/stderr")
    check "$cmd > /dev/full exits 3" test "$rc" -eq 3
    check "$cmd > /dev/full says so" grep -q "error: cannot write to standard output" <<<"$err"
done
finish
