#!/usr/bin/env bash
# Replays every input that fuzzing and hostile use found getting through (issue #18, one block
# per row) and asserts what the user must see: exit 2 (or the stated code), a message naming
# the file and the element, nothing left in --out. The deep and large inputs are generated
# here, not committed. Usage: hostile_input.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc=$rc) $err"; }
run() {  # run ARGS... -> sets rc, err; a hang is a failure (rc 124)
    timeout 120 "$bin" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    err=$(head -c 2000 "$tmp/stderr")
}
# refused NAME PATTERN OUT: exit 2, the message matches PATTERN (file and element), OUT absent.
refused() {
    check "$1: exit 2" test "$rc" -eq 2
    check "$1: message names file and element" grep -q -E -- "$2" <<<"$err"
    check "$1: nothing in --out" test ! -e "$3"
}
export PENUMBRA_CACHE_DIR="$tmp/cache"

# Inputs: a 64x64 scenario on the bundled scene, and small glTF scenes built by one generator.
cp "$src/data/default/scene.glb" "$tmp/"
scenario() {  # scenario FILE LIGHTS [CAMERA] [EXTRA_KEYS] -> a scenario on scene.glb
    local cam=${3:-'{"type": "perspective", "eye": [4.5, 4, 9], "target": [0, 0.6, 0], "yfov_deg": 45}'}
    printf '{"scene": "%s", "image": {"width": 64, "height": 64}, "camera": %s, "lights": %s%s}\n' \
        "${SCENE:-scene.glb}" "$cam" "$2" "${4:-}" >"$1"
}
sun='[{"type": "directional", "direction": [0.3, -1, -0.2]}]'
python3 - "$tmp" <<'PY'
import base64, copy, json, struct, sys
out = sys.argv[1]
pos = struct.pack("<12f", -5, 0, -5, 5, 0, -5, 5, 0, 5, -5, 0, 5)
idx = struct.pack("<6H", 0, 2, 1, 0, 3, 2)
base = {
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
    "extensionsUsed": ["KHR_lights_punctual"],
    "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 3, 8], "rotation": [-0.17, 0, 0, 0.985]},
              {"translation": [0, 4, 0], "rotation": [-0.7071068, 0, 0, 0.7071068],
               "extensions": {"KHR_lights_punctual": {"light": 0}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                   "min": [-5, 0, -5], "max": [5, 0, 5]},
                  {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    "bufferViews": [{"buffer": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
    "buffers": [{"byteLength": 60, "uri": "data:application/octet-stream;base64," +
                 base64.b64encode(pos + idx).decode()}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "spot", "spot": {"outerConeAngle": 0.6}}]}},
}
def write(name, doc, text=None):
    with open(f"{out}/{name}", "w") as f:
        f.write(text if text is not None else json.dumps(doc))
def variant(name, edit):
    d = copy.deepcopy(base)
    edit(d)
    write(name, d)
write("ok.gltf", base)
# 1, 10: cameras and lights out of the range the oracle is right for.
variant("ortho_1e19.gltf", lambda d: d["cameras"].__setitem__(0, {"type": "orthographic",
        "orthographic": {"xmag": 1e19, "ymag": 1e19, "znear": 0.1, "zfar": 100}}))
variant("ortho_tiny.gltf", lambda d: d["cameras"].__setitem__(0, {"type": "orthographic",
        "orthographic": {"xmag": 5e-324, "ymag": 1, "znear": 0.1, "zfar": 100}}))
variant("eye_1e20.gltf", lambda d: d["nodes"][1].__setitem__("translation", [1e20, 3, 8]))
variant("znear_huge.gltf", lambda d: d["cameras"][0]["perspective"].__setitem__("znear", 1e300))
variant("znear_denormal.gltf", lambda d: d["cameras"][0]["perspective"].__setitem__("znear", 5e-324))
variant("zfar_negative.gltf", lambda d: d["cameras"][0]["perspective"].__setitem__("zfar", -1))
variant("point_1e300.gltf", lambda d: (d["extensions"]["KHR_lights_punctual"]["lights"].__setitem__(0, {"type": "point"}),
        d["nodes"][2].__setitem__("translation", [1e300, 0, 0])))
variant("cone_inverted.gltf", lambda d: d["extensions"]["KHR_lights_punctual"]["lights"][0]["spot"].update(
        {"innerConeAngle": 0.7, "outerConeAngle": 0.6}))
# 2, 3: deep nesting in extras, and a wrongly typed deep value.
d = copy.deepcopy(base); d["extras"] = "@"
write("deep_extras.gltf", None, json.dumps(d).replace('"@"', "[" * 20000 + "]" * 20000))
d = copy.deepcopy(base); d["nodes"][0]["mesh"] = "@"
write("deep_typed.gltf", None, json.dumps(d).replace('"@"', "[" * 100000 + "1" + "]" * 100000))
# 12: bytes after a NUL.
write("nul.gltf", None, json.dumps(base) + "\0 trailing bytes")
# 14: glTF 1.0 and a root listed twice.
write("gltf1.gltf", {"asset": {"version": "1.0"}, "scene": "defaultScene", "scenes": {"defaultScene": {"nodes": []}}})
variant("dup_roots.gltf", lambda d: d["scenes"][0].__setitem__("nodes", [0, 0, 1, 2]))
# 8: 1.8 MB that expands to 1.5 billion triangles: one mesh of 300,000 triangles used by
# 5000 nodes.
tris = 300000
big_idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3) * (tris // 2)
bin_ = pos + big_idx
d = copy.deepcopy(base)
d["nodes"] = [{"mesh": 0} for _ in range(5000)]
d["scenes"] = [{"nodes": list(range(5000))}]
d["cameras"] = []
d["extensions"] = {}
d["extensionsUsed"] = []
d["accessors"][1]["count"] = tris * 3
d["bufferViews"][1]["byteLength"] = len(big_idx)
d["buffers"] = [{"byteLength": len(bin_)}]
js = json.dumps(d).encode()
js += b" " * (-len(js) % 4)
bin_ += b"\0" * (-len(bin_) % 4)
glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(bin_)) + \
      struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(bin_), b"BIN\0") + bin_
open(f"{out}/huge.glb", "wb").write(glb)
# 4, 5: deep technique and gate, in a scenario and as files.
deep = lambda n: "[" * n + "]" * n
open(f"{out}/deep_technique.json", "w").write('{"resolution": ' + deep(500000) + "}")  # within 1 MiB
open(f"{out}/deep_gate.json", "w").write('{"checks": ' + deep(150000) + "}")
PY

# Row 1: a glTF orthographic camera with xmag 1e19 (Embree aborted on its rays).
SCENE=ortho_1e19.gltf scenario "$tmp/r1.json" "$sun" '{"gltf_camera": 0}'
run oracle "$tmp/r1.json" --out "$tmp/o1" -q
refused "row 1 oracle" 'ortho_1e19\.gltf: cameras\[0\].*xmag.*1e\+19' "$tmp/o1"
run validate "$tmp/r1.json" --out "$tmp/o1v" -q
refused "row 1 validate" 'ortho_1e19\.gltf: cameras\[0\].*xmag' "$tmp/o1v"

# Row 2: extras nested 20,000 deep (tinygltf recursed without a limit).
SCENE=deep_extras.gltf scenario "$tmp/r2.json" "$sun"
run oracle "$tmp/r2.json" --out "$tmp/o2" -q
refused "row 2" 'deep_extras\.gltf: extras.*nested deeper than 64' "$tmp/o2"

# Row 3: a wrongly typed value nested 100,000 deep (the schema check's message dumped it).
SCENE=deep_typed.gltf scenario "$tmp/r3.json" "$sun"
run oracle "$tmp/r3.json" --out "$tmp/o3" -q
refused "row 3" 'deep_typed\.gltf: nodes\[0\]\.mesh.*nested deeper than 64' "$tmp/o3"

# Row 4: a scenario whose technique or gate nests 150,000 deep.
scenario "$tmp/r4t.json" "$sun" "" ", \"technique\": $(python3 -c 'print("["*150000 + "]"*150000)')"
run oracle "$tmp/r4t.json" --out "$tmp/o4t" -q
refused "row 4 technique" 'r4t\.json: technique.*nested deeper than 64' "$tmp/o4t"
scenario "$tmp/r4g.json" "$sun" "" ", \"gate\": {\"checks\": $(python3 -c 'print("["*150000 + "]"*150000)')}"
run validate "$tmp/r4g.json" --out "$tmp/o4g" -q
refused "row 4 gate" 'r4g\.json: gate\.checks.*nested deeper than 64' "$tmp/o4g"

# Row 5: --technique FILE nesting 500,000 deep; --gate FILE 150,000 deep.
scenario "$tmp/s.json" "$sun"
run raster "$tmp/s.json" --out "$tmp/o5" --technique "$tmp/deep_technique.json" -q
refused "row 5 --technique" 'deep_technique\.json: resolution.*nested deeper than 64' "$tmp/o5"
run validate "$tmp/s.json" --out "$tmp/o5g" --gate "$tmp/deep_gate.json" -q
refused "row 5 --gate" 'deep_gate\.json: checks.*nested deeper than 64' "$tmp/o5g"

run raster "$tmp/s.json" --out "$tmp/o5s" --set "$(python3 -c 'print("a." * 60000 + "b=1")')" -q
refused "row 5 --set with a 60,000-segment key" '--set.*60001 segments' "$tmp/o5s"

# Row 6: names that are not UTF-8 are refused; paths that are not UTF-8 just work.
run raster "$tmp/s.json" --out "$tmp/o6a" --set preset=$'\xff\xfe' -q
refused "row 6 --set" '--set.*not valid UTF-8' "$tmp/o6a"
run raster "$tmp/s.json" --out "$tmp/o6b" --preset $'caf\xe9' -q
refused "row 6 --preset" '--preset.*caf\\xE9.*not valid UTF-8' "$tmp/o6b"
latin=$'d\xe9j\xe0'
mkdir -p "$tmp/$latin" && cp "$tmp/scene.glb" "$tmp/s.json" "$tmp/$latin/"
run validate "$tmp/$latin/s.json" --out "$tmp/o6c" -q
check "row 6 a Latin-1 scenario path validates" test "$rc" -eq 0
check "row 6 a Latin-1 scenario path writes report.json" test -s "$tmp/o6c/report.json"
run validate "$tmp/s.json" --out "$tmp/o6d" -q --cache "$tmp/cache-$latin"
check "row 6 a Latin-1 --cache validates" test "$rc" -eq 0
run validate "$tmp/s.json" --out "$tmp/o6e" -q --cache "$tmp/cache-$latin"
check "row 6 a Latin-1 --cache is read back" grep -q '"oracle_cached": true' "$tmp/o6e/report.json"
for i in 1 2; do
    (
        unset PENUMBRA_CACHE_DIR
        export XDG_CACHE_HOME="$tmp/xdg-$latin"
        run validate "$tmp/s.json" --out "$tmp/o6f$i" -q
        echo "$rc" >"$tmp/rc6f$i"
    )
    check "row 6 a Latin-1 XDG_CACHE_HOME validates (run $i)" test "$(cat "$tmp/rc6f$i")" -eq 0
done
check "row 6 the second run used the XDG cache" grep -q '"oracle_cached": true' "$tmp/o6f2/report.json"

# Row 7: NaN options (every comparison with NaN is false, so ranges let it through).
run validate "$tmp/s.json" --out "$tmp/o7a" --tolerance nan -q
refused "row 7 --tolerance" '--tolerance.*not a finite number' "$tmp/o7a"
run oracle "$tmp/s.json" --out "$tmp/o7b" --area-target nan -q
refused "row 7 --area-target" '--area-target.*not a finite number' "$tmp/o7b"

# Row 8: refused up front with the estimate and its biggest term (exit 2, not 3 or the OOM killer).
SCENE=huge.glb scenario "$tmp/r8a.json" "$sun"
run oracle "$tmp/r8a.json" --out "$tmp/o8a" -q
refused "row 8 a small file of billions of triangles" 'huge\.glb: needs about .* GiB.*biggest: scene \(1500000000 triangles' \
    "$tmp/o8a"
lights100=$(python3 -c 'import json; print(json.dumps([{"type": "point", "position": [0, 3 + i * 0.01, 0]} for i in range(100)]))')
scenario "$tmp/r8b.json" "$lights100"
sed -i 's/"width": 64, "height": 64/"width": 8192, "height": 8192/' "$tmp/r8b.json"
run oracle "$tmp/r8b.json" --out "$tmp/o8b" -q
refused "row 8 8192^2 with 100 lights" 'r8b\.json: needs about .*(TiB|GiB).*biggest: oracle frame \(8192x8192 px, 100 lights\)' \
    "$tmp/o8b"
scenario "$tmp/r8c.json" "$sun"
sed -i 's/"width": 64, "height": 64/"width": 8192, "height": 8192/' "$tmp/r8c.json"
run validate "$tmp/r8c.json" --out "$tmp/o8c" -q --max-memory 8G
refused "row 8 8192^2 with one light under --max-memory 8G" 'r8c\.json: needs about .* GiB.*more than the 8\.0 GiB' "$tmp/o8c"
(
    ulimit -v 4000000  # a memory cap: the default budget follows RLIMIT_AS
    run validate "$tmp/r8c.json" --out "$tmp/o8e" -q
    echo "$rc" >"$tmp/rc8e"
    echo "$err" >"$tmp/err8e"
)
rc=$(cat "$tmp/rc8e") err=$(cat "$tmp/err8e")
refused "row 8 8192^2 with one light under ulimit -v 4 GB" 'r8c\.json: needs about .* GiB.*more than the 2\.[0-9] GiB' "$tmp/o8e"
run oracle "$tmp/s.json" --out "$tmp/o8d" -q --max-memory lots
refused "row 8 a bad --max-memory" '--max-memory lots' "$tmp/o8d"

# Row 9: a rect light with 1e100 m edges (the oracle's truth was silently wrong).
scenario "$tmp/r9.json" '[{"type": "rect", "center": [0, 3, 0], "u": [1e100, 0, 0], "v": [0, 0, 1]}]'
run oracle "$tmp/r9.json" --out "$tmp/o9" -q
refused "row 9" 'r9\.json: lights\[0\]\.u: edge length 1e\+100 m exceeds' "$tmp/o9"

# Row 10: glTF cameras and lights get the scenario's checks.
for case in "ortho_tiny:cameras\[0\].*xmag" "eye_1e20:cameras\[0\].*eye.*1e\+20" "znear_huge:cameras\[0\].*znear" \
    "znear_denormal:cameras\[0\].*znear" "zfar_negative:cameras\[0\].*zfar"; do
    name=${case%%:*}
    SCENE=$name.gltf scenario "$tmp/r10.json" "$sun" '{"gltf_camera": 0}'
    run oracle "$tmp/r10.json" --out "$tmp/o10" -q
    refused "row 10 $name" "$name\\.gltf: ${case#*:}" "$tmp/o10"
done
for case in "point_1e300:KHR_lights_punctual\.lights\[0\] \(placed by nodes\[2\]\): position.*1e\+300" \
    "cone_inverted:KHR_lights_punctual\.lights\[0\].*inner_cone_deg"; do
    name=${case%%:*}
    SCENE=$name.gltf scenario "$tmp/r10.json" '"gltf"'
    run oracle "$tmp/r10.json" --out "$tmp/o10" -q
    refused "row 10 $name" "$name\\.gltf: ${case#*:}" "$tmp/o10"
done
SCENE=ok.gltf scenario "$tmp/r10ok.json" '"gltf"' '{"gltf_camera": 0}'
run oracle "$tmp/r10ok.json" --out "$tmp/o10ok" -q
check "row 10 a sane glTF camera and light still work" test "$rc" -eq 0

# Row 11: what is not a regular file is refused, never read forever.
run oracle /dev/zero --out "$tmp/o11a" -q
refused "row 11 /dev/zero scenario" '/dev/zero: not a regular file' "$tmp/o11a"
run raster "$tmp/s.json" --out "$tmp/o11b" --technique /dev/zero -q
refused "row 11 --technique /dev/zero" '/dev/zero: not a regular file' "$tmp/o11b"
run validate "$tmp/s.json" --out "$tmp/o11c" --gate /dev/zero -q
refused "row 11 --gate /dev/zero" '/dev/zero: not a regular file' "$tmp/o11c"
mkfifo "$tmp/fifo.json"
run oracle "$tmp/fifo.json" --out "$tmp/o11d" -q
refused "row 11 a FIFO" 'fifo\.json: not a regular file' "$tmp/o11d"
SCENE=fifo.json scenario "$tmp/r11.json" "$sun"
run oracle "$tmp/r11.json" --out "$tmp/o11e" -q
refused "row 11 a FIFO as the scene" 'fifo\.json: not a regular file' "$tmp/o11e"

# Row 12: NUL bytes.
scenario "$tmp/r12a.json" "$sun"
printf '\0{"scene": "nope"}' >>"$tmp/r12a.json"
run oracle "$tmp/r12a.json" --out "$tmp/o12a" -q
refused "row 12 bytes after a NUL" 'r12a\.json: invalid JSON at byte [0-9]+: a NUL byte' "$tmp/o12a"
SCENE='scene.glb\u0000.txt' scenario "$tmp/r12b.json" "$sun"
run oracle "$tmp/r12b.json" --out "$tmp/o12b" -q
refused "row 12 a NUL in the scene path" 'r12b\.json: scene: contains a NUL character' "$tmp/o12b"
SCENE=nul.gltf scenario "$tmp/r12c.json" "$sun"
run oracle "$tmp/r12c.json" --out "$tmp/o12c" -q
refused "row 12 bytes after a NUL in a glTF" 'nul\.gltf: JSON: a NUL byte' "$tmp/o12c"

# Row 13: --junit is checked before any work.
run validate "$tmp/s.json" --out "$tmp/o13a" --junit "$tmp/o13a" -q
refused "row 13 --junit equal to --out" '--junit .*o13a: is the --out folder' "$tmp/o13a"
touch "$tmp/plain"
run validate "$tmp/s.json" --out "$tmp/o13b" --junit "$tmp/plain/j.xml" -q
refused "row 13 --junit under a file" '--junit .*plain/j\.xml: .*plain is not a folder' "$tmp/o13b"
run validate "$tmp/s.json" --out "$tmp/o13c" --junit /proc/j.xml -q
refused "row 13 --junit where nothing can be created" '--junit /proc/j\.xml: cannot write into /proc' "$tmp/o13c"
if [ "$(id -u)" -ne 0 ]; then  # root writes into read-only folders
    mkdir "$tmp/ro" && chmod a-w "$tmp/ro"
    run validate "$tmp/s.json" --out "$tmp/o13d" --junit "$tmp/ro/j.xml" -q
    refused "row 13 --junit in a read-only folder" '--junit .*ro/j\.xml: cannot write into' "$tmp/o13d"
fi

# Row 14: messages that say what is wrong; duplicates warned about.
scenario "$tmp/r14a.json" '[{"type": "directional", "direction": [1e308, -1e308, 0]}]'
run oracle "$tmp/r14a.json" --out "$tmp/o14a" -q
refused "row 14 an overflowing direction" 'r14a\.json: lights\[0\]\.direction: length overflows' "$tmp/o14a"
scenario "$tmp/r14b.json" '[{"type": "rect", "center": [0, 3, 0], "u": [1e200, 0, 0], "v": [0, 0, 1]}]'
run oracle "$tmp/r14b.json" --out "$tmp/o14b" -q
refused "row 14 a 1e200 rect edge" 'r14b\.json: lights\[0\]\.u: edge length 1e\+200 m exceeds' "$tmp/o14b"
SCENE=gltf1.gltf scenario "$tmp/r14c.json" "$sun"
run oracle "$tmp/r14c.json" --out "$tmp/o14c" -q
refused "row 14 glTF 1.0" 'gltf1\.gltf: asset\.version: glTF "1\.0" is not supported' "$tmp/o14c"
SCENE=dup_roots.gltf scenario "$tmp/r14d.json" "$sun"
run oracle "$tmp/r14d.json" --out "$tmp/o14d"
check "row 14 duplicate roots: exit 0" test "$rc" -eq 0
check "row 14 duplicate roots: a warning" grep -q 'dup_roots\.gltf: scene lists root node 0 more than once' <<<"$err"
check "row 14 duplicate roots: geometry once" grep -q ' 2 triangles' "$tmp/stdout"

finish
