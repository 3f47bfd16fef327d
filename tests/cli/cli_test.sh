#!/usr/bin/env bash
# End-to-end checks of the penumbra command line: exit codes, messages, no partial output,
# bit-identical results whatever the thread count. Usage: cli_test.sh PENUMBRA SOURCE_DIR
set -uo pipefail
bin=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
check() {  # check NAME CONDITION...
    local name=$1
    shift
    if "$@"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAIL: $name"; fi
}
run() {  # run OUT_DIR ARGS... -> sets rc, err
    "$bin" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    err=$(cat "$tmp/stderr")
}

# A good run writes exactly the promised files.
run oracle "$src/data/default/scenario.json" --out "$tmp/a" --threads 1 -q
check "default scenario exits 0" test "$rc" -eq 0
for f in oracle.exr oracle.json oracle.png; do check "writes $f" test -s "$tmp/a/$f"; done
check "no temporaries left" test -z "$(ls -A "$tmp/a" | grep -v -E '^oracle\.(exr|json|png)$')"
check "oracle.json counts rays" grep -q '"shadow":' "$tmp/a/oracle.json"

# Deterministic: the same EXR bytes with 1 and 2 threads.
run oracle "$src/data/default/scenario.json" --out "$tmp/b" --threads 2 -q
check "two threads exit 0" test "$rc" -eq 0
check "oracle.exr is bit-identical across thread counts" cmp -s "$tmp/a/oracle.exr" "$tmp/b/oracle.exr"

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

# Area lights are refused clearly until the soft-shadow oracle exists.
sed 's/"type": "directional", "direction": \[0, 0, 0\]/"type": "sphere", "center": [0, 3, 0], "radius": 0.5/' "$tmp/bad.json" >"$tmp/sphere.json"
run oracle "$tmp/sphere.json" --out "$tmp/d"
check "area light exits 2" test "$rc" -eq 2
check "area light message" grep -q "lights\[0\]: sphere lights are not supported by the oracle yet" <<<"$err"
check "area light writes nothing" test ! -e "$tmp/d"

# A failing run into an existing folder leaves what was there and nothing else.
mkdir -p "$tmp/e" && echo keep >"$tmp/e/keep.txt"
run oracle "$tmp/bad.json" --out "$tmp/e"
check "existing folder untouched" test "$(ls -A "$tmp/e")" = "keep.txt"

# Malformed glTF through the CLI.
if [ -d /usr/share/assimp/models/glTF2/IndexOutOfRange ]; then
    sed "s#\"scene.glb\"#\"/usr/share/assimp/models/glTF2/IndexOutOfRange/IndexOutOfRange.gltf\"#" "$tmp/bad.json" |
        sed 's/"direction": \[0, 0, 0\]/"direction": [0, -1, 0]/' >"$tmp/oob.json"
    run oracle "$tmp/oob.json" --out "$tmp/f"
    check "malformed glTF exits 2" test "$rc" -eq 2
    check "malformed glTF message names the element" grep -q "IndexOutOfRange.gltf: meshes\[0\].primitives\[0\].indices" <<<"$err"
    check "malformed glTF writes nothing" test ! -e "$tmp/f"
fi

# Usage errors.
run
check "no subcommand exits 2" test "$rc" -eq 2
run oracle "$src/data/default/scenario.json"
check "missing --out exits 2" test "$rc" -eq 2
run oracle "$tmp/nope.json" --out "$tmp/g"
check "missing scenario exits 2" test "$rc" -eq 2

echo "$passed passed, $failed failed"
test "$failed" -eq 0
