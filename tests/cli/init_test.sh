#!/usr/bin/env bash
# `penumbra init` end to end on models nobody here wrote (Debian's assimp-testmodels, issue #33):
# the scenario it writes runs with validate as it is and frames the model (at least a fifth of the
# pixels are the model or its ground, seen by both paths); a unit warning with the line to add;
# no overwrite without --force; a bad model is exit 2 with nothing written; Z-up and heightfield
# models converted with assimp, and several models in one scenario.
# Usage: init_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
export PENUMBRA_CACHE_DIR="$tmp/cache"
fail_detail() { echo "(rc=$rc: ${err:0:300})"; }

models=/usr/share/assimp/models/glTF2
require_tool assimp-testmodels "$models/BoxTextured-glTF/BoxTextured.gltf" || { finish; exit; }

# The fraction of the image's pixels that are a surface (model or receiver) for the oracle, and
# the fraction of those where the raster path sees another triangle (or none).
coverage() {  # coverage REPORT -> "surface_fraction mismatch_fraction"
    python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
p = r['lights'][0]['pixels']
print(p['surface'] / (r['image']['width'] * r['image']['height']), p['coverage_mismatch'] / max(p['surface'], 1))" "$1"
}
at_least() { python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) >= float(sys.argv[2]) else 1)" "$1" "$2"; }

# The issue's "Done when": init with --ground on a model without a camera, then validate.
box=$models/BoxTextured-glTF/BoxTextured.gltf
run init "$box" --out "$tmp/box/scenario.json" --ground
check "init exits 0" test "$rc" -eq 0
check "init prints the triangle count" grep -q "BoxTextured.gltf: 12 triangles" "$tmp/stdout"
check "init prints the bounds" grep -q "bounds: \[-0.5, -0.5, -0.5\] to \[0.5, 0.5, 0.5\] m" "$tmp/stdout"
check "init prints the size" grep -q "size: 1 x 1 x 1 m" "$tmp/stdout"
check "init frames a camera" grep -q "camera: a 3/4 view from above" "$tmp/stdout"
check "init adds a sun" grep -q "lights: a sun at elevation" "$tmp/stdout"
check "no unit warning on a 1 m model" fails grep -q "suggests" "$tmp/stderr"
check "the scene path is relative to the scenario" python3 -c "
import json, os, sys
s = json.load(open('$tmp/box/scenario.json'))
sys.exit(0 if not os.path.isabs(s['scene']) and os.path.samefile(os.path.join('$tmp/box', s['scene']), '$box') else 1)"
check "the ground is a plane receiver at the model's base" python3 -c "
import json, sys
r = json.load(open('$tmp/box/scenario.json'))['receivers']
sys.exit(0 if len(r) == 1 and r[0]['type'] == 'plane' and r[0]['center'][1] == -0.5 else 1)"
check "nothing but the scenario is written" test "$(ls -A "$tmp/box")" = "scenario.json"
run validate "$tmp/box/scenario.json" --out "$tmp/box/run" --preset d3d12-textbook --no-cache -q
check "validate runs init's scenario as it is" test "$rc" -eq 0
read -r surface mismatch <<<"$(coverage "$tmp/box/run/report.json")"
check "at least a fifth of the pixels are the model or its ground ($surface)" at_least "$surface" 0.2
check "the raster path sees the same surfaces, ground included ($mismatch)" at_least 0.01 "$mismatch"

# Without --ground the model alone covers less: the plane is what the extra pixels are.
run init "$box" --out "$tmp/bare/scenario.json" -q
run validate "$tmp/bare/scenario.json" --out "$tmp/bare/run" --preset d3d12-textbook --no-cache -q
check "validate without ground exits 0" test "$rc" -eq 0
read -r bare _ <<<"$(coverage "$tmp/bare/run/report.json")"
check "the model alone is framed too ($bare)" at_least "$bare" 0.2
check "the ground adds surface pixels ($bare < $surface)" at_least "$surface" "$(python3 -c "print($bare + 0.1)")"

# A real model in millimetres, with its own camera: the warning says which line to add.
engine=$models/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
run init "$engine" --out "$tmp/engine/scenario.json" --ground
check "engine: init exits 0" test "$rc" -eq 0
check "engine: the model's own camera" grep -q "camera: the model's own, cameras\[0\]" "$tmp/stdout"
check "engine: warns of millimetres, as a guess" grep -q "warning: 2CylinderEngine.glb is 743.4 m across, which suggests millimetres (a guess from its size)" <<<"$err"
check "engine: prints the line to add" grep -qF "add \"scale\": 0.001 to $tmp/engine/scenario.json" <<<"$err"
run init "$engine" --out "$tmp/engine-m/scenario.json" --ground --scale 0.001
check "engine --scale 0.001: exits 0" test "$rc" -eq 0
check "engine --scale 0.001: no warning" fails grep -q "suggests" <<<"$err"
check "engine --scale 0.001: the size in metres" grep -q "size: 0.7434 x 0.273 x 0.268 m" "$tmp/stdout"
check "engine --scale 0.001: the scenario's scale" grep -q '"scale": 0.001' "$tmp/engine-m/scenario.json"
run validate "$tmp/engine-m/scenario.json" --out "$tmp/engine-m/run" --preset d3d12-textbook --no-cache -q
check "engine: validate runs the scaled scenario" test "$rc" -eq 0
read -r engine_surface _ <<<"$(coverage "$tmp/engine-m/run/report.json")"
check "engine: at least a fifth of the pixels are the model or its ground ($engine_surface)" at_least "$engine_surface" 0.2

# --sun: the direction the light travels, from the sun's elevation and azimuth.
run init "$box" --out "$tmp/sun/scenario.json" --sun 90,0 -q
check "--sun 90,0 lights straight down" python3 -c "
import json, sys
d = json.load(open('$tmp/sun/scenario.json'))['lights'][0]['direction']
sys.exit(0 if abs(d[0]) < 1e-9 and abs(d[1] + 1) < 1e-9 and abs(d[2]) < 1e-9 else 1)"
for bad in "0,10" "91,0" "45" "45,x" "45,1000" "nan,0"; do
    run init "$box" --out "$tmp/badsun/scenario.json" --sun "$bad"
    check "--sun $bad exits 2" test "$rc" -eq 2
    check "--sun $bad names the option" grep -q -- "--sun" <<<"$err"
done
check "a bad --sun writes nothing" test ! -e "$tmp/badsun"

# Never overwrite by accident; --force does, atomically.
before=$(cat "$tmp/box/scenario.json")
run init "$box" --out "$tmp/box/scenario.json" --sun 60,10
check "an existing scenario is exit 2" test "$rc" -eq 2
check "the message says --force" grep -q "box/scenario.json: exists; pass --force to overwrite it" <<<"$err"
check "the existing scenario is untouched" test "$(cat "$tmp/box/scenario.json")" = "$before"
run init "$box" --out "$tmp/box/scenario.json" --sun 60,10 --force -q
check "--force overwrites" test "$rc" -eq 0
check "--force wrote the new sun" test "$(cat "$tmp/box/scenario.json")" != "$before"
check "no temporaries left" test -z "$(ls -A "$tmp/box" | grep -v -E '^(scenario\.json|run)$')"
run init "$box" --out "$tmp/box" --force
check "a folder as --out is exit 2" test "$rc" -eq 2

# A bad model: exit 2 naming the file and the reason, nothing written.
run init "$models/IndexOutOfRange/IndexOutOfRange.gltf" --out "$tmp/oob/scenario.json"
check "a malformed model is exit 2" test "$rc" -eq 2
check "the message names the file, element and reason" grep -q "IndexOutOfRange.gltf: meshes\[0\].primitives\[0\].indices: index 255 .* is out of range" <<<"$err"
check "a malformed model writes nothing" test ! -e "$tmp/oob"
run init "$tmp/none.glb" --out "$tmp/none/scenario.json"
check "a missing model is exit 2" test "$rc" -eq 2
check "a missing model is named" grep -q "none.glb: no such file" <<<"$err"
check "a missing model writes nothing" test ! -e "$tmp/none"
run init "$models/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf" --out "$tmp/points/scenario.json"
check "a model without triangles is exit 2" test "$rc" -eq 2
check "a model without triangles is said so" grep -q "Mesh_PrimitiveMode_00.gltf: no triangles" <<<"$err"
check "a model without triangles writes nothing" test ! -e "$tmp/points"
cp "$box" "$tmp/model.obj"
run init "$tmp/model.obj" --out "$tmp/obj/scenario.json"
check "a model that is not glTF is exit 2" test "$rc" -eq 2
check "a model that is not glTF is said so" grep -q "model.obj: expected a glTF 2.0 file (.gltf or .glb)" <<<"$err"

run init "$box" --out ""
check "an empty --out is exit 2" test "$rc" -eq 2
cp "$box" "$tmp/self.gltf"
cp "$(dirname "$box")/BoxTextured0.bin" "$tmp/"
run init "$tmp/self.gltf" --out "$tmp/self.gltf" --force
check "--out naming the model itself is exit 2, even with --force" test "$rc" -eq 2
check "--out naming the model itself is said so" grep -q "self.gltf: is the model itself" <<<"$err"
check "the model is untouched" cmp -s "$box" "$tmp/self.gltf"
touch "$tmp/a-file"
run init "$box" --out "$tmp/a-file/scenario.json"
check "--out under a file is exit 2" test "$rc" -eq 2
# A model a millionth of a micrometre across: no camera or ground fits the scenario's limits.
python3 -c "
import json, sys
g = json.load(open('$box'))
g['nodes'][0]['matrix'] = [v * 1e-13 for v in g['nodes'][0]['matrix'][:12]] + g['nodes'][0]['matrix'][12:]
json.dump(g, open('$tmp/tiny.gltf', 'w'))"
run init "$tmp/tiny.gltf" --out "$tmp/tiny/scenario.json" --ground
check "a model too small to frame is exit 2" test "$rc" -eq 2
check "a model too small to frame points at --scale" grep -q "tiny.gltf: .* m across, .*--scale brings its units to metres" <<<"$err"
check "a model too small to frame writes nothing" test ! -e "$tmp/tiny"

# The model's own KHR_lights_punctual lights are taken as they are.
python3 - "$box" "$tmp/lit" <<'PY'
import json, os, shutil, sys
src, dst = sys.argv[1], sys.argv[2]
os.makedirs(dst)
g = json.load(open(src))
for b in g["buffers"]:
    shutil.copy(os.path.join(os.path.dirname(src), b["uri"]), dst)
g["images"] = []
g["textures"] = []
for m in g.get("materials", []):
    m.get("pbrMetallicRoughness", {}).pop("baseColorTexture", None)
g["extensionsUsed"] = g.get("extensionsUsed", []) + ["KHR_lights_punctual"]
g["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point"}]}}
g["nodes"].append({"translation": [2, 3, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}})
g["scenes"][0]["nodes"].append(len(g["nodes"]) - 1)
json.dump(g, open(os.path.join(dst, "lit.gltf"), "w"))
PY
run init "$tmp/lit/lit.gltf" --out "$tmp/lit/scenario.json"
check "a model with lights: init exits 0" test "$rc" -eq 0
check "a model with lights: takes them" grep -q '"lights": "gltf"' "$tmp/lit/scenario.json"
check "a model with lights: says so" grep -q "lights: the model's 1 KHR_lights_punctual lights" "$tmp/stdout"
check "a model with lights: the scene is next to the scenario" grep -q '"scene": "lit.gltf"' "$tmp/lit/scenario.json"
run camera "$tmp/lit/scenario.json" -q
check "a model with lights: the scenario loads" test "$rc" -eq 0

# Third-party models in other formats, converted with assimp (issue #53): a heightfield that is
# Z-up, an AMF print (Z-up, standing on z = 0), several models in one scenario; the far plane
# init writes lets cascades and engine presets run without editing a file.
if require_tool assimp-utils assimp; then
    a=/usr/share/assimp/models
    mkdir -p "$tmp/conv"
    assimp export "$a/HMP/terrain.hmp" "$tmp/conv/terrain.glb" -fglb2 >/dev/null
    assimp export "$a/AMF/test1.amf" "$tmp/conv/print.glb" -fglb2 >/dev/null
    run init "$tmp/conv/terrain.glb" --out "$tmp/terrain/scenario.json" --ground --width 320 --height 180
    check "terrain: init exits 0" test "$rc" -eq 0
    check "terrain: 160 m across is read as a site in metres, not centimetres" grep -q "terrain.glb: 160 m across and flat or one open sheet: read as a terrain or site in metres" "$tmp/stdout"
    check "terrain: no unit warning" fails grep -q "suggests" <<<"$err"
    check "terrain: said to look Z-up, with the evidence" grep -q 'terrain.glb looks modelled with +Z up (a guess: 80% of its area faces -Z' <<<"$err"
    check "terrain: stood upright" python3 -c "
import json; s = json.load(open('$tmp/terrain/scenario.json')); assert s['up'] == 'z', s"
    check "terrain: a far plane beyond the ground" python3 -c "
import json; c = json.load(open('$tmp/terrain/scenario.json'))['camera']; assert c['zfar'] > c['znear'] > 0, c"
    for t in "--preset three-csm" "--set family=cascaded" "--preset d3d12-textbook"; do
        run validate "$tmp/terrain/scenario.json" --out "$tmp/terrain/run" $t --no-cache -q
        check "terrain: validate $t runs init's scenario as it is" test "$rc" -eq 0
    done
    # Stood upright, the heightfield's faces point down (its winding is inverted, as init said):
    # the camera sees through it from above, and validate names the mesh and leads its hint with it.
    run validate "$tmp/terrain/scenario.json" --out "$tmp/terrain/facing" --no-cache
    check "terrain: validate warns that the mesh is seen from behind, naming it" \
        grep -qE 'warning: nodes\[0\] "terrain_root": [0-9]+% of its [0-9]+ pixels meet the back of single-sided triangles' <<<"$err"
    check "terrain: the false_lit hint names the back faces first" \
        grep -qE 'hint: false_lit .*the likely causes, in order: [0-9]+% of the frame meets the back of single-sided' "$tmp/stdout"
    check "terrain: report.json's facing names the mesh" python3 -c "
import json; f = json.load(open('$tmp/terrain/facing/report.json'))['facing']
assert f['meshes'][0]['mesh'] == 'nodes[0] \"terrain_root\"' and f['meshes'][0]['share'] > 0.5, f"
    check "terrain: facing.png and report.html's facing view" test -s "$tmp/terrain/facing/facing.png"
    check "terrain: report.html has a facing section" grep -q 'id="facing"' "$tmp/terrain/facing/report.html"
    check "terrain: report.html's facing table" grep -q 'nodes\[0\] &quot;terrain_root&quot;\|nodes\[0\] "terrain_root"' "$tmp/terrain/facing/report.html"
    run init "$tmp/conv/terrain.glb" --out "$tmp/terrain-y/scenario.json" --up y -q
    check "terrain --up y: no up key" fails grep -q '"up": "z"' "$tmp/terrain-y/scenario.json"

    run init "$tmp/conv/print.glb" "$box" "$tmp/conv/terrain.glb" --out "$tmp/three/scenario.json" --ground --width 320 --height 180
    check "three models: init exits 0" test "$rc" -eq 0
    check "three models: each counted, and in all" grep -q "3 models: 2064 triangles" "$tmp/stdout"
    check "three models: the print stands on z = 0, said" grep -q "print.glb (scene\[0\]) looks modelled with +Z up (a guess: it stands on z = 0" <<<"$err"
    check "three models: a list, the Z-up ones stood upright" python3 -c "
import json; s = json.load(open('$tmp/three/scenario.json'))['scene']
assert len(s) == 3 and s[0]['up'] == 'z' and isinstance(s[1], str) and s[2]['up'] == 'z', s"
    run validate "$tmp/three/scenario.json" --out "$tmp/three/run" --preset three-csm --no-cache -q
    check "three models: validate runs" test "$rc" -eq 0
    check "three models: oracle.json lists the models" python3 -c "
import json; assert len(json.load(open('$tmp/three/run/oracle.json'))['scene']) == 3"
    read -r three_surface _ <<<"$(coverage "$tmp/three/run/report.json")"
    check "three models: framed ($three_surface)" at_least "$three_surface" 0.2
fi

# --help: the outputs and an example.
run init --help
check "init --help exits 0" test "$rc" -eq 0
check "init --help lists the output" grep -q "Output: the scenario file" "$tmp/stdout"
check "init --help has an example" grep -q "penumbra init model.glb --out" "$tmp/stdout"

finish
