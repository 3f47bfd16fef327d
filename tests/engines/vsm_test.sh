#!/usr/bin/env bash
# Light bleeding in a real engine's frame (issue #35): three.js renders make_vsm_scene.py's crate
# under a high roof with renderer.shadowMap.type = VSMShadowMap, and `penumbra compare --moments`
# must find light bleeding where Chebyshev's bound lets light through onto ground the crate
# shadows; the same frame with three's default PCFShadowMap has none. Skipped (exit 77) as
# engines_test.sh: only when node or chromium is missing, and never in CI (CI set: a failure).
# Usage: vsm_test.sh PENUMBRA SOURCE_DIR
set -uo pipefail
bin=$1 src=$2
source "$src/tests/engines/setup.sh"  # here, skip, the tools, tmp
python3 "$here/make_vsm_scene.py" "$tmp" || { echo "FAIL: make_vsm_scene.py"; exit 1; }
camera_for_pages
# VSM's blur: 8 texels (three's shadow.radius) of a 1024 map; PCF for the contrast.
cat >"$tmp/configs.json" <<'JSON'
[{"name": "vsm", "light": 0, "mapSize": 1024, "shadowMapType": "VSMShadowMap", "radius": 8, "blurSamples": 16},
 {"name": "pcf", "light": 0, "mapSize": 1024}]
JSON
node "$here/render.mjs" three "$tmp/camera.json" "$tmp/scene.glb" "$tmp/configs.json" "$tmp/three" ||
    { echo "FAIL: three.js did not render"; exit 1; }
failed=0
for name in vsm pcf; do
    # The filter reaches the blur's 8 texels and the bilinear tap's one.
    "$bin" compare "$tmp/scenario.json" --light 0 --image "$tmp/three/$name.shadow.pfm" \
        --depth "$tmp/three/$name.depth.pfm" --depth-space linear --shadow-map 1024 --filter-reach 9 --moments \
        --out "$tmp/c_$name" -q || { echo "FAIL: compare on three.js $name"; failed=1; }
done
[[ $failed == 0 ]] || exit 1
PYTHONPATH=$here python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
from checks import check, finish
vsm_report = json.load(open(f"{tmp}/c_vsm/report.json"))
vsm, pcf = vsm_report["lights"][0], json.load(open(f"{tmp}/c_pcf/report.json"))["lights"][0]
check("three.js VSMShadowMap: frame lines up (depth)", vsm_report["coverage"]["mismatch_fraction"] < 0.01,
      f"coverage mismatch {vsm_report['coverage']['mismatch_fraction']:.4f}")
bleeding = vsm["counts"]["light_bleeding"]
# The dominant error is reported, not required: VSM also leaks light at the crate's foot (the
# classic contact leak, peter-panning by its occluder's distance) and blurs every edge (aliasing).
dominant = max(vsm["counts"], key=vsm["counts"].get)
check("three.js VSMShadowMap: light bleeding found", bleeding > 100,
      f"light_bleeding {bleeding} px; dominant {dominant}; all {vsm['counts']}")
check("three.js PCFShadowMap: far less of it", pcf["counts"]["light_bleeding"] * 5 < bleeding,
      f"light_bleeding {pcf['counts']['light_bleeding']} px; all {pcf['counts']}")
finish()
PY
