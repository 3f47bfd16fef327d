# Sourced by the engine tests (engines_test.sh, presets_test.sh, vsm_test.sh) after `bin=$1 src=$2`:
# `here`, `skip`, the tools a real engine needs, a scratch folder `tmp` (removed on exit unless
# KEEP is set) that holds the oracle cache, and the two functions below. Their Python checks
# import checks.py (PYTHONPATH=$here). A missing node or chromium skips (exit 77)
# outside CI and fails in CI (CI set); missing npm packages always fail.
here=$src/tests/engines
skip() {
    [[ -n ${CI:-} ]] && { echo "FAIL: $1 (CI must run this test; scripts/install-deps.sh installs it)"; exit 1; }
    echo "SKIP: $1 (optional outside CI; scripts/install-deps.sh installs it)"
    exit 77
}
command -v node >/dev/null || skip "node is not installed"
chromium=${CHROMIUM:-/usr/bin/chromium}
[[ -x $chromium ]] || skip "no chromium at $chromium"
[[ -d $here/node_modules/three && -d $here/node_modules/babylonjs && -d $here/node_modules/puppeteer-core ]] ||
    { echo "FAIL: tests/engines/node_modules is missing: run scripts/install-deps.sh (npm ci in tests/engines)"; exit 1; }
tmp=$(mktemp -d)
trap '[[ -n ${KEEP:-} ]] || rm -rf "$tmp"' EXIT
export PENUMBRA_CACHE_DIR=$tmp/cache

# data/default at 320x180, its scene by absolute path, in $tmp/scenario.json.
small_default_scenario() {
    sed "s#\"scene.glb\"#\"$src/data/default/scene.glb\"#; s/\"width\": 1280, \"height\": 720/\"width\": 320, \"height\": 180/" \
        "$src/data/default/scenario.json" >"$tmp/scenario.json"
}

# $tmp/scenario.json's camera in the GL convention the pages take, in $tmp/camera.json.
camera_for_pages() {
    "$bin" camera "$tmp/scenario.json" --convention gl >"$tmp/camera.json" || { echo "FAIL: penumbra camera"; exit 1; }
}
