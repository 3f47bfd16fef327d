#!/usr/bin/env bash
# End-to-end checks of the penumbra command line: exit codes, messages, no partial output,
# bit-identical results whatever the thread count. Usage: cli_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"

# A good run writes exactly the promised files.
run oracle "$src/data/default/scenario.json" --out "$tmp/a" --threads 1 -q
check "default scenario exits 0" test "$rc" -eq 0
for f in oracle.exr oracle.json oracle.png; do check "writes $f" test -s "$tmp/a/$f"; done
check "no temporaries left" test -z "$(ls -A "$tmp/a" | grep -v -E '^oracle\.(exr|json|png)$')"
check "oracle.json counts rays" grep -q '"shadow":' "$tmp/a/oracle.json"
check "oracle.json times the frame's allocation" grep -q '"frame":' "$tmp/a/oracle.json"
check "oracle.json counts the rays that locate shadow boundaries" grep -q -E '"boundary": [1-9][0-9]*,?$' "$tmp/a/oracle.json"

# Deterministic: the same EXR bytes with 1 and 2 threads.
run oracle "$src/data/default/scenario.json" --out "$tmp/b" --threads 2 -q
check "two threads exit 0" test "$rc" -eq 0
check "oracle.exr is bit-identical across thread counts" cmp -s "$tmp/a/oracle.exr" "$tmp/b/oracle.exr"
check "oracle.png is bit-identical across thread counts" cmp -s "$tmp/a/oracle.png" "$tmp/b/oracle.png"
# From two threads oracle.exr is written during the boundary phase (its own time: exr_early);
# at one, after it, beside the PNG.
check "oracle.json times the early oracle.exr at two threads" grep -q '"exr_early":' "$tmp/b/oracle.json"
check "oracle.json has no early oracle.exr at one thread" bash -c "! grep -q '\"exr_early\":' '$tmp/a/oracle.json'"

# Bad scenario: exit 2, the JSON path named, nothing written.
cp "$src/data/default/scene.glb" "$tmp/"
cat >"$tmp/bad.json" <<'JSON'
{"scene": "scene.glb", "image": {"width": 64, "height": 64},
 "camera": {"type": "perspective", "eye": [0, 2, 5], "target": [0, 0, 0], "yfov_deg": 45},
 "lights": [{"type": "directional", "direction": [0, 0, 0]}]}
JSON
run oracle "$tmp/bad.json" --out "$tmp/c"
check "zero direction exits 2" test "$rc" -eq 2
check "zero direction message" grep -q "bad.json: lights\[0\].direction: zero vector" <<<"$err"
check "bad input creates no output folder" test ! -e "$tmp/c"

# Area lights: sampled adaptively, reported in oracle.json, the same image for a seed.
sed 's/"type": "directional", "direction": \[0, 0, 0\]/"type": "sphere", "center": [0, 3, 0], "radius": 0.5/' "$tmp/bad.json" >"$tmp/sphere.json"
run oracle "$tmp/sphere.json" --out "$tmp/d" --seed 7 -q
check "sphere light exits 0" test "$rc" -eq 0
check "oracle.json has rays per pixel" grep -q '"rays_per_pixel"' "$tmp/d/oracle.json"
check "oracle.json has the convergence curve" grep -q '"convergence"' "$tmp/d/oracle.json"
run oracle "$tmp/sphere.json" --out "$tmp/d2" --seed 7 --threads 1 -q
check "same seed, same oracle.exr" cmp -s "$tmp/d/oracle.exr" "$tmp/d2/oracle.exr"
run oracle "$tmp/sphere.json" --out "$tmp/d3" --area-target 0
check "a zero target exits 2" test "$rc" -eq 2
check "a zero target writes nothing" test ! -e "$tmp/d3"

# A failing run into an existing folder leaves what was there and nothing else.
mkdir -p "$tmp/e" && echo keep >"$tmp/e/keep.txt"
run oracle "$tmp/bad.json" --out "$tmp/e"
check "existing folder untouched" test "$(ls -A "$tmp/e")" = "keep.txt"

# Malformed glTF through the CLI.
if require_tool assimp-testmodels /usr/share/assimp/models/glTF2/IndexOutOfRange; then
    sed "s#\"scene.glb\"#\"/usr/share/assimp/models/glTF2/IndexOutOfRange/IndexOutOfRange.gltf\"#" "$tmp/bad.json" |
        sed 's/"direction": \[0, 0, 0\]/"direction": [0, -1, 0]/' >"$tmp/oob.json"
    run oracle "$tmp/oob.json" --out "$tmp/f"
    check "malformed glTF exits 2" test "$rc" -eq 2
    check "malformed glTF message names the element and the reason" grep -q "IndexOutOfRange.gltf: meshes\[0\].primitives\[0\].indices: index 255 .* is out of range" <<<"$err"
    check "malformed glTF writes nothing" test ! -e "$tmp/f"
fi

# raster: the promised files, the technique echoed, the device named; deterministic output.
run raster "$src/data/default/scenario.json" --out "$tmp/r1" -q --preset d3d12-textbook --set resolution=512
check "raster exits 0" test "$rc" -eq 0
for f in raster.exr raster.json raster.png; do check "raster writes $f" test -s "$tmp/r1/$f"; done
check "raster.json records the technique" grep -q '"preset": "d3d12-textbook"' "$tmp/r1/raster.json"
check "raster.json records the override" grep -q '"resolution": 512' "$tmp/r1/raster.json"
check "raster.json names the device" grep -q '"name": "llvmpipe' "$tmp/r1/raster.json"
check "raster.json has GPU pass times" grep -q '"shadow":' "$tmp/r1/raster.json"
run raster "$src/data/default/scenario.json" --out "$tmp/r2" -q --preset d3d12-textbook --set resolution=512 --threads 1
check "raster.exr is bit-identical across runs" cmp -s "$tmp/r1/raster.exr" "$tmp/r2/raster.exr"
# --threads bounds the whole command (the load, the raster), not only an oracle.
check "raster --threads 1 runs on one thread" grep -q '"threads": 1,' "$tmp/r2/raster.json"

# raster: bad techniques are bad input, named, with nothing written.
run raster "$src/data/default/scenario.json" --out "$tmp/r3" --set filter.type=gaussian
check "unknown filter exits 2" test "$rc" -eq 2
check "unknown filter message" grep -q "technique.filter.type: \"gaussian\" is not one of" <<<"$err"
check "unknown filter writes nothing" test ! -e "$tmp/r3"
run raster "$src/data/default/scenario.json" --out "$tmp/r4" --set resolution=99999
check "absurd resolution exits 2" test "$rc" -eq 2
run raster "$src/data/default/scenario.json" --out "$tmp/r5" --preset nope
check "unknown preset exits 2" test "$rc" -eq 2
check "unknown preset lists presets" grep -q "camera-frustum-article" <<<"$err"
run raster "$src/data/default/scenario.json" --out "$tmp/r6" --device no-such-gpu
check "unknown device exits 2" test "$rc" -eq 2
check "unknown device lists devices" grep -q "llvmpipe" <<<"$err"
run raster "$tmp/sphere.json" --out "$tmp/r7" --preset pcss -q
check "raster draws a sphere light with PCSS" test "$rc" -eq 0
check "raster.json names the soft-shadow method" grep -q '"method": "pcss"' "$tmp/r7/raster.json"
run raster "$tmp/sphere.json" --out "$tmp/r7b" --set area_samples=300
check "too many area samples exit 2" test "$rc" -eq 2
# The technique family is picked by its key: an unknown one is bad input naming the known ones.
run raster "$src/data/default/scenario.json" --out "$tmp/r7c" --set family=moments
check "unknown technique family exits 2" test "$rc" -eq 2
check "unknown technique family is named with the known ones" \
    grep -q 'technique.family: "moments" is not a technique family (have "depth_map", "averaged_area", "cascaded"' <<<"$err"
run raster "$src/data/default/scenario.json" --out "$tmp/r7d" -q --set family=cascaded --set cascades.sdsm=true
check "cascades.sdsm true draws" test "$rc" -eq 0
check "SDSM's reduction is a timed pass and its range is in raster.json" python3 -c "
import json; r = json.load(open('$tmp/r7d/raster.json'))
assert 'sdsm_reduce' in r['gpu_ms'] and 'sdsm_reduce' in r['gpu_passes']
s = r['lights'][0]['sdsm']; assert 0.1 <= s['near_m'] < s['far_m'] <= 100, s"
run raster "$src/data/default/scenario.json" --out "$tmp/r7e" --set family=cascaded --set cascades.sdsm=yes
check "cascades.sdsm not a boolean is exit 2 naming its key path" grep -q 'technique.cascades.sdsm' <<<"$err"
check "unknown technique family writes nothing" test ! -e "$tmp/r7c"
check "raster.json's technique names its family" python3 -c "
import json; assert json.load(open('$tmp/r7/raster.json'))['technique']['family'] == 'depth_map'"

# raster: no Vulkan driver at all is an environment failure (exit 3) that says what to install.
VK_ICD_FILENAMES=/nonexistent.json run raster "$src/data/default/scenario.json" --out "$tmp/r8"
check "no Vulkan device exits 3" test "$rc" -eq 3
check "no Vulkan device says what to install" grep -q "mesa-vulkan-drivers" <<<"$err"
check "no Vulkan device writes nothing" test ! -e "$tmp/r8"

run devices
check "devices lists lavapipe" grep -q "llvmpipe" "$tmp/stdout"
run raster --help
check "raster --help lists the presets" grep -q "diligent-tutorial13" "$tmp/stdout"

# validate: oracle (cached) + raster + metrics, reports, gates, JUnit, the HTML in a browser.
sed -e 's/"width": 1280/"width": 320/' -e 's/"height": 720/"height": 180/' "$src/data/default/scenario.json" >"$tmp/small.json"
export PENUMBRA_CACHE_DIR="$tmp/cache"
run validate "$tmp/small.json" --out "$tmp/v1" -q
check "validate exits 0" test "$rc" -eq 0
for f in report.json report.html raster.json oracle.json light0.classes.png light2.error.png light1.compare.png; do
    check "validate writes $f" test -s "$tmp/v1/$f"
done
check "validate writes no errors.exr without --errors or --frames" test ! -e "$tmp/v1/errors.exr"
# Two runs' verdicts are the same when every light's class map and error map are (their pixels
# and legends, with each class's rate, are the verdict's).
same_verdict() {
    local f
    for f in light0.classes.png light1.classes.png light2.classes.png light0.error.png light1.error.png light2.error.png; do
        cmp -s "$1/$f" "$2/$f" || return 1
    done
}
check "first validate traces the oracle" grep -q '"oracle_cached": false' "$tmp/v1/report.json"
check "the oracle is stored in the cache" test -n "$(ls "$tmp/cache"/oracle-*.bin 2>/dev/null)"
run validate "$tmp/small.json" --out "$tmp/v2" -q --errors
check "second validate reads the cached oracle" grep -q '"oracle_cached": true' "$tmp/v2/report.json"
# The spot light's class map paints its outside apart from back faces (#53): a colour that covers
# a good share of the spot's map and none of the sun's or the point light's, traced (the frame's
# points) and cached (the cache keeps triangles, not points) alike.
at_least() { python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) >= float(sys.argv[2]) else 1)" "$1" "$2"; }
cone_colour_share() {  # RUN: the share of light1.classes.png in a colour absent from light0's and light2's
    python3 - "$1" <<'PY'
import struct, sys, zlib
from collections import Counter
def pixels(path):  # 8-bit RGB or RGBA PNG, every filter type
    data = open(path, "rb").read()
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    bpp = 3 if ctype == 2 else 4
    raw, stride, prev, out = zlib.decompress(idat), w * bpp, bytearray(w * bpp), Counter()
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            p = a + b - c
            pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c][f]
            line[i] = (line[i] + pred) & 255
        out.update(bytes(line[x * bpp:x * bpp + 3]) for x in range(w))
        prev = line
    return out, w * h
spot, n = pixels(f"{sys.argv[1]}/light1.classes.png")
others = set(pixels(f"{sys.argv[1]}/light0.classes.png")[0]) | set(pixels(f"{sys.argv[1]}/light2.classes.png")[0])
print(max((c / n for colour, c in spot.items() if colour not in others), default=0.0))
PY
}
for v in v1 v2; do
    share=$(cone_colour_share "$tmp/$v")
    check "$v: the spot's outside has a colour of its own ($share of the map)" at_least "$share" 0.05
done
check "report.html names the outside of the cone" grep -q "outside the spot light's cone" "$tmp/v1/report.html"
check "a cached oracle gives the same verdict" same_verdict "$tmp/v1" "$tmp/v2"
check "validate --errors writes errors.exr" test -s "$tmp/v2/errors.exr"
run validate "$tmp/small.json" --out "$tmp/v3" -q --set resolution=256 --threads 1
check "validate --threads 1 runs the raster and the metrics on one thread" grep -q '"threads": 1,' "$tmp/v3/raster.json"
check "another technique reuses the oracle" grep -q '"oracle_cached": true' "$tmp/v3/report.json"
differs=1
same_verdict "$tmp/v1" "$tmp/v3" && differs=0
check "another technique gives another verdict" test "$differs" -eq 1
sed 's/"width": 320/"width": 322/' "$tmp/small.json" >"$tmp/small2.json"
run validate "$tmp/small2.json" --out "$tmp/v4" -q
check "another image size misses the cache" grep -q '"oracle_cached": false' "$tmp/v4/report.json"
run validate "$tmp/small.json" --out "$tmp/v5" -q --no-cache
check "--no-cache traces" grep -q '"oracle_cached": false' "$tmp/v5/report.json"
run validate "$tmp/small.json" --out "$tmp/v7" -q --frames
for f in oracle.exr oracle.png raster.exr raster.png errors.exr; do check "validate --frames writes $f" test -s "$tmp/v7/$f"; done
check "--frames traces the oracle (the cache lacks its G-buffer)" grep -q '"oracle_cached": false' "$tmp/v7/report.json"
run validate "$tmp/small.json" --out "$tmp/v7t" -q --class-map-tint cascades
check "--class-map-tint takes none or cascade: another is exit 2 writing nothing" test "$rc" -eq 2 -a ! -e "$tmp/v7t"
# The entry small.json's runs read (oracle.json names it), not whichever sorts first.
cache_file() { python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["cache"]["file"])' "$1/oracle.json"; }
entry=$(cache_file "$tmp/v2")
echo "garbage" >"$entry"
run validate "$tmp/small.json" --out "$tmp/v6" -q
check "a damaged cache entry is traced again, not an error" test "$rc" -eq 0
# Bytes flipped in the middle of an entry (its size and header intact) are found by its
# checksum: a warning, the oracle traced again, the same verdict.
rm -f "$entry"  # the garbage is not penumbra's: left where it was; the next run stores the entry again
run validate "$tmp/small.json" --out "$tmp/v6b" -q
entry=$(cache_file "$tmp/v6b")
size=$(stat -c %s "$entry")
printf '\xff\xfe\xfd\xfc' | dd of="$entry" bs=1 seek=$((size / 2)) conv=notrunc status=none
run validate "$tmp/small.json" --out "$tmp/v8" --errors
check "a cache entry with flipped bytes exits 0" test "$rc" -eq 0
check "a cache entry with flipped bytes is named in a warning" grep -q "warning: .*oracle-.*damaged" <<<"$err"
check "a cache entry with flipped bytes is traced again" grep -q '"oracle_cached": false' "$tmp/v8/report.json"
check "a cache entry with flipped bytes gives the same verdict" cmp -s "$tmp/v2/errors.exr" "$tmp/v8/errors.exr"
# A temporary of a store that was killed (its name, its process gone, the entry header it
# writes first) is swept by the next store; a file of the old, guessable shape is the user's
# and stays (#50).
killed="$tmp/cache/.oracle-00000000000000000000000000000000.bin.tmp-4194000-0123456789abcdef"
printf 'PNBORCL2' >"$killed"
touch "$tmp/cache/.oracle-00000000000000000000000000000000.tmp-999999999"
run validate "$tmp/small.json" --out "$tmp/v9" -q --area-max-rays 17
check "a killed store's temporary is swept" test ! -e "$killed"
check "a file of a temporary's old shape stays" test -e "$tmp/cache/.oracle-00000000000000000000000000000000.tmp-999999999"

# A bad --out is refused before any work (no oracle traced, nothing cached).
touch "$tmp/a-file"
PENUMBRA_CACHE_DIR="$tmp/cache-badout" run validate "$tmp/small.json" --out "$tmp/a-file"
check "--out naming a file exits 2" test "$rc" -eq 2
check "--out naming a file says so" grep -q "a-file: exists and is not a folder" <<<"$err"
check "--out naming a file is refused before the oracle runs" test ! -e "$tmp/cache-badout"
run validate "$tmp/small.json" --out ""
check "--out \"\" exits 2" test "$rc" -eq 2
check "--out \"\" says it is empty" grep -q -- "--out.*empty" <<<"$err"
if [[ $(id -u) -ne 0 ]]; then
    mkdir "$tmp/ro" && chmod a-w "$tmp/ro"
    run oracle "$tmp/small.json" --out "$tmp/ro/x"
    check "--out in a read-only folder exits 2" test "$rc" -eq 2
fi
run oracle "$tmp/small.json" --out /proc/penumbra-out
check "--out where nothing can be written exits 2" test "$rc" -eq 2
check "--out where nothing can be written names the folder" grep -q "cannot write into /proc" <<<"$err"

# The commit is all or nothing: a folder in the way of one output (report.html) fails the run
# before any file is replaced, and leaves no temporary.
run validate "$tmp/small.json" --out "$tmp/v10" -q
check "validate into a fresh folder exits 0" test "$rc" -eq 0
cp "$tmp/v10/report.json" "$tmp/v10-report.before"
rm "$tmp/v10/report.html" && mkdir "$tmp/v10/report.html"
run validate "$tmp/small.json" --out "$tmp/v10" -q --set bias.constant=3
check "a folder in the way of an output exits 2" test "$rc" -eq 2
check "a folder in the way is named" grep -q "report.html: is a folder" <<<"$err"
check "a folder in the way: no file was replaced" cmp -s "$tmp/v10/report.json" "$tmp/v10-report.before"
check "a folder in the way: no temporary left" test -z "$(ls -A "$tmp/v10" | grep tmp-)"

# --size WxH replaces the scenario's image for one run, keyed apart in the oracle cache (#53).
run validate "$tmp/small.json" --out "$tmp/sz" -q --size 40x24 --cache "$tmp/szcache"
check "--size exits 0" test "$rc" -eq 0
check "--size is the image judged" python3 -c "
import json; i = json.load(open('$tmp/sz/report.json'))['image']; assert (i['width'], i['height']) == (40, 24), i"
run validate "$tmp/small.json" --out "$tmp/sz2" -q --size 48x24 --cache "$tmp/szcache"
check "another --size is another oracle frame" test "$(ls "$tmp/szcache" | grep -c '^oracle-')" -eq 2
for bad in 0x10 40 40x 9000x9000 "40x24x2"; do
    run validate "$tmp/small.json" --out "$tmp/szbad" --size "$bad"
    check "--size $bad exits 2, naming the option" grep -q -- "--size" <<<"$err"
    check "--size $bad writes nothing" test ! -e "$tmp/szbad"
done

require_tool xmllint xmllint
junit_ok() { xmllint --noout --schema "$src/tests/cli/junit.xsd" "$1" 2>"$tmp/xmllint.log"; }

# Gates: exit 0 when every check passes, 1 with one line per failure, 2 for a bad gate.
echo '{"checks": [{"metric": "rates.acne", "max": 1.0}, {"metric": "wrong_fraction", "max": 0.5, "light": 0}]}' >"$tmp/pass.json"
run validate "$tmp/small.json" --out "$tmp/g1" -q --gate "$tmp/pass.json" --junit "$tmp/g1.xml"
check "passing gate exits 0" test "$rc" -eq 0
check "report.json records the gate" grep -q '"passed": true' "$tmp/g1/report.json"
check "JUnit validates against the CI schema" junit_ok "$tmp/g1.xml"
check "JUnit has one testcase per light x check" test "$(grep -c '<testcase ' "$tmp/g1.xml")" -eq 4
echo '{"checks": [{"metric": "rates.aliasing", "max": 0}, {"metric": "mae", "max": 1}]}' >"$tmp/fail.json"
run validate "$tmp/small.json" --out "$tmp/g2" -q --gate "$tmp/fail.json" --junit "$tmp/g2.xml"
check "failing gate exits 1" test "$rc" -eq 1
check "each failure on one line" grep -q -E '^light 0: rates\.aliasing = [0-9.e-]+ > 0$' <<<"$err"
check "only failures are printed" test "$(grep -c '^light' <<<"$err")" -eq 3
check "failing gate still writes its report" grep -q '"passed": false' "$tmp/g2/report.json"
check "failing JUnit validates" junit_ok "$tmp/g2.xml"
check "JUnit counts the failures" grep -q 'failures="3"' "$tmp/g2.xml"
# The summary counts what failed (the first of two checks fails on each of 3 lights, the second passes).
run validate "$tmp/small.json" --out "$tmp/g2s" --gate "$tmp/fail.json"
check "the gate summary counts the failures, of all checks" grep -q '^gate: FAILED (3 of 6 checks failed)$' "$tmp/stdout"
sed 's/ classname="[^"]*"//' "$tmp/g2.xml" >"$tmp/bad.xml"
check "the schema rejects a testcase without a classname" fails junit_ok "$tmp/bad.xml"
echo '{"checks": [{"metric": "rates.acnee", "max": 0}]}' >"$tmp/badgate.json"
run validate "$tmp/small.json" --out "$tmp/g3" --gate "$tmp/badgate.json"
check "unknown gate metric exits 2" test "$rc" -eq 2
check "unknown gate metric names the path" grep -q 'badgate.json: checks\[0\].metric: unknown metric "rates.acnee"' <<<"$err"
check "bad gate writes nothing" test ! -e "$tmp/g3"
sed 's/"technique"/"gate": {"checks": [{"metric": "rates.false_lit", "max": 0, "light": 1}]}, "technique"/' "$tmp/small.json" >"$tmp/gated.json"
run validate "$tmp/gated.json" --out "$tmp/g4" -q
check "the scenario's own gate applies" test "$rc" -eq 1
check "the scenario's gate names its light" grep -q '^light 1: rates.false_lit' <<<"$err"

# The HTML report opens in headless Chromium with every image decoded and no console message;
# a page with a broken image shows that this check can fail.
check "chromium is installed" test -x "$(command -v chromium)"
check "report.html renders cleanly in Chromium" html_check "$tmp/g2/report.html"
check "report.html shows the command that made it" grep -q "Made by <code>penumbra validate " "$tmp/g2/report.html"
check "report.json records the command line" grep -q '"command_line": "penumbra validate ' "$tmp/g2/report.json"
sed 's#data:image/png;base64,[^"]*#data:image/png;base64,AAAA#' "$tmp/g2/report.html" >"$tmp/broken.html"
check "a broken report is caught" fails html_check "$tmp/broken.html"
sed 's#<h2>#<table style="width:3000px"><tr><td>wide</td></tr></table><h2>#' "$tmp/g2/report.html" >"$tmp/wide.html"
check "a report wider than 1280 px is caught" fails html_check "$tmp/wide.html"
unset PENUMBRA_CACHE_DIR

# Every command's --help lists what it writes and one example (issue 33).
for c in oracle raster validate devices tune compare camera sweep merge stress init diff cache; do
    check "$c --help lists outputs and an example" bash -c "'$bin' $c --help | grep -q '^Outputs\?' && '$bin' $c --help | grep -q '^Example:'"
done

# Usage errors.
run
check "no subcommand exits 2" test "$rc" -eq 2
run oracle "$src/data/default/scenario.json"
check "missing --out exits 2" test "$rc" -eq 2
run oracle "$tmp/nope.json" --out "$tmp/g"
check "missing scenario exits 2" test "$rc" -eq 2

# PCSS needs a light with a size: on a directional light it is bad input (exit 2) naming the
# key and the light, refused before any work (validate traces no oracle, caches nothing).
run raster "$src/data/default/scenario.json" --out "$tmp/p1" --preset pcss
check "pcss on a directional light exits 2" test "$rc" -eq 2
check "pcss on a directional light names the key and the light" grep -q -F \
    'scenario.json: technique.filter.type: "pcss" (from preset "pcss") needs a light with a size; lights[0] is directional' <<<"$err"
check "pcss on a directional light writes nothing" test ! -e "$tmp/p1"
PENUMBRA_CACHE_DIR="$tmp/cache-pcss" run validate "$tmp/small.json" --out "$tmp/p2" --set filter.type=pcss
check "validate: pcss on a directional light exits 2" test "$rc" -eq 2
check "validate: pcss on a directional light names the key and the light" grep -q -F \
    'small.json: technique.filter.type: "pcss" needs a light with a size; lights[0] is directional' <<<"$err"
check "validate: pcss is refused before the oracle runs" test ! -e "$tmp/cache-pcss"
check "validate: pcss refused writes nothing" test ! -e "$tmp/p2"

# raster.json names each map's texel size by its unit: the default scenario has both kinds.
check "raster.json: orthographic maps give metres_per_texel" grep -q '"metres_per_texel":' "$tmp/r1/raster.json"
check "raster.json: perspective maps give metres_per_texel_per_metre" \
    grep -q '"metres_per_texel_per_metre":' "$tmp/r1/raster.json"

finish
