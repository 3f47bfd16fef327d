#!/usr/bin/env bash
# docs/quickstart.md, run as a reader would: every ```sh block of the page, in order, in an empty
# folder with penumbra on the PATH; each must exit 0. The blocks must equal the copy below, so
# the page's commands cannot change without this test (and a run of them) changing too.
# Usage: quickstart_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
export PENUMBRA_CACHE_DIR="$tmp/cache"  # the page's validate and tune use the default cache

page=$src/docs/quickstart.md
require_tool assimp-testmodels /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb ||
    { finish; exit; }

# The page's shell blocks, separated by a line "#--- block N".
python3 - "$page" >"$tmp/blocks.sh" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
for n, block in enumerate(re.findall(r"^```sh\n(.*?)^```$", text, re.S | re.M)):
    print(f"#--- block {n}")
    print(block, end="")
PY

cat >"$tmp/expected.sh" <<'SH'
#--- block 0
cp /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb model.glb
penumbra init model.glb --out shadows/scenario.json --ground
#--- block 1
penumbra init model.glb --out shadows/scenario.json --ground --scale 0.001 --force
#--- block 2
penumbra validate shadows/scenario.json --out shadows/run --preset d3d12-textbook
#--- block 3
grep -A6 '"rates_visible"' shadows/run/report.json
#--- block 4
penumbra tune shadows/scenario.json --out shadows/tune --preset d3d12-textbook --budget 30
#--- block 5
cat >shadows/gate.json <<'EOF'
{"checks": [{"metric": "rates_visible.acne", "max": 0.001},
            {"metric": "rates_visible.peter_panning", "max": 0.005},
            {"metric": "pixels.scored", "min": 100000}]}
EOF
penumbra validate shadows/scenario.json --out shadows/ci --technique shadows/tune/technique.json \
    --gate shadows/gate.json --junit shadows/ci/junit.xml
SH
if ! diff -u "$tmp/expected.sh" "$tmp/blocks.sh"; then
    echo "docs/quickstart.md's commands differ from this test's copy: update both, and run them"
fi
check "the page's commands are the ones this test runs" cmp -s "$tmp/expected.sh" "$tmp/blocks.sh"

# Run each block of the page (not the copy) in a fresh folder, in order.
mkdir "$tmp/work"
bin_dir=$(cd "$(dirname "$bin")" && pwd)
n=$(grep -c '^#--- block' "$tmp/blocks.sh")
for ((i = 0; i < n; i++)); do
    awk -v b="#--- block $i" '$0 == b {on = 1; next} /^#--- block/ {on = 0} on' "$tmp/blocks.sh" >"$tmp/block$i.sh"
    (cd "$tmp/work" && PATH="$bin_dir:$PATH" bash -e -o pipefail "$tmp/block$i.sh") \
        >"$tmp/block$i.out" 2>"$tmp/block$i.err"
    rc=$?
    check "quickstart block $i exits 0 (rc=$rc: $(tail -c 300 "$tmp/block$i.err"))" test "$rc" -eq 0
done

# What the page says the reader will see.
warning=$(grep '^warning: .* across, which suggests millimetres' "$page")
check "the page quotes init's unit warning" test -n "$warning"
check "the page quotes init's unit warning as init prints it" grep -qxF "$warning" "$tmp/block0.err"
check "init wrote the scaled scenario" grep -q '"scale": 0.001' "$tmp/work/shadows/scenario.json"
check "validate wrote report.html" test -s "$tmp/work/shadows/run/report.html"
check "the report's visible rates were shown" grep -q '"acne":' "$tmp/block3.out"
check "tune wrote technique.json" test -s "$tmp/work/shadows/tune/technique.json"
check "the CI gate passed" grep -q "gate: passed (3 checks)" "$tmp/block5.out"
check "the CI run wrote JUnit" grep -q "<testsuite" "$tmp/work/shadows/ci/junit.xml"

finish
