#!/usr/bin/env bash
# Cut-outs in a real engine (issue #48): three.js renders make_cutout_scene.py's checkerboard card
# (alphaMode MASK: GLTFLoader's alphaTest, which three's shadow pass honours with an alpha-tested
# depth material) and its double-sided sheet with its back to the sun, with its defaults (as
# presets_test.sh: mapSize 512, PCFShadowMap, bias 0, shadowSide null). `penumbra compare` judges
# three's frame and `penumbra validate --preset three` penumbra's copy of those defaults; the two
# verdicts must agree on the dominant class and within a factor of 2 on its rate. Skipped (exit 77)
# as engines_test.sh: only when node or chromium is missing, and never in CI.
# Usage: cutout_test.sh PENUMBRA SOURCE_DIR (KEEP=1: keep the frames and reports)
set -uo pipefail
bin=$1 src=$2
source "$src/tests/engines/setup.sh"  # here, skip, the tools, tmp
python3 "$here/make_cutout_scene.py" "$tmp" || { echo "FAIL: make_cutout_scene.py"; exit 1; }
camera_for_pages
"$bin" validate "$tmp/scenario.json" --preset three --out "$tmp/v" -q || { echo "FAIL: validate --preset three"; exit 1; }
read -r fit reach < <(python3 -c 'import json, sys
t = json.load(open(sys.argv[1]))["technique"]
f = t["filter"]
half = 0.5 if f.get("bilinear_taps") else 0
print(t["fit"], max(1.0, f.get("radius_texels", f.get("size", 2) / 2) + half))' "$tmp/v/report.json")
echo "[{\"name\": \"default\", \"light\": 0, \"mapSize\": 512, \"fit\": \"$fit\"}]" >"$tmp/configs.json"
node "$here/render.mjs" three "$tmp/camera.json" "$tmp/scene.glb" "$tmp/configs.json" "$tmp/three" ||
    { echo "FAIL: three.js did not render"; exit 1; }
texel=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["texel_m"])' "$tmp/three/default.json")
bias=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["bias_m"])' "$tmp/three/default.json")
"$bin" compare "$tmp/scenario.json" --light 0 --image "$tmp/three/default.shadow.pfm" --depth "$tmp/three/default.depth.pfm" \
    --depth-space linear --bias-m "$bias" --texel-m "$texel" --filter-reach "$reach" --out "$tmp/c" -q ||
    { echo "FAIL: compare on three.js's frame"; exit 1; }
PYTHONPATH=$here python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
from checks import check, finish
classes = ["acne", "peter_panning", "aliasing", "false_shadow", "false_lit", "light_bleeding"]
report = json.load(open(f"{tmp}/c/report.json"))
e, p = report["lights"][0], json.load(open(f"{tmp}/v/report.json"))["lights"][0]
pct = lambda x: f"{100 * x:.3f}%"
row = "  ".join(f"{c} {pct(e['rates'][c])} | {pct(p['rates'][c])}" for c in classes if e["rates"][c] or p["rates"][c])
check("three.js's frame lines up (depth)", report["coverage"]["mismatch_fraction"] < 0.01,
      f"coverage mismatch {report['coverage']['mismatch_fraction']:.4f}: three sees through the holes as the truth does")
de, dp = max(classes, key=lambda c: e["rates"][c]), max(classes, key=lambda c: p["rates"][c])
check("the dominant class agrees", de == dp, f"three {de} | preset {dp}; {row}")
a, b = e["rates"][de], p["rates"][de]
check(f"its rate within a factor of 2", min(a, b) > 0 and max(a, b) <= 2 * min(a, b), f"{de} {pct(a)} | {pct(b)}")
check("no false_shadow in the holes in either", e["rates"]["false_shadow"] < 0.002 and p["rates"]["false_shadow"] < 0.002,
      f"false_shadow {pct(e['rates']['false_shadow'])} | {pct(p['rates']['false_shadow'])}")
finish()
PY
