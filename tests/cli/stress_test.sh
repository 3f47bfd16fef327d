#!/usr/bin/env bash
# `penumbra stress` end to end on a reduced suite (docs/stress.md): the files, the oracle
# invariant, the gate's exit codes, JUnit, bad input. Usage: stress_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
cases=grazing_89.99,far_1e7,scale_1e4,contact_wedge_1deg,needles,spot_179

# The reduced suite: every file, every case, the oracle invariant on each.
run stress --out "$tmp/a" --cases "$cases" --preset d3d12-textbook --junit "$tmp/a.xml" -q
check "reduced suite exits 0" test "$rc" -eq 0
for f in stress.json report.html far_1e7.light0.classes.png needles.light1.classes.png; do
    check "writes $f" test -s "$tmp/a/$f"
done
check "stress.json has the six cases" test "$(grep -o '"oracle_invariant": true' "$tmp/a/stress.json" | wc -l)" -eq 6
check "stress.json has no oracle failure" grep -q '"oracle_invariant_failures": 0' "$tmp/a/stress.json"
check "stress.json names differing pixels" grep -q '"differing_pixels": 0' "$tmp/a/stress.json"
check "stress.json judges far cases at the origin too" grep -q '"lights_at_canonical"' "$tmp/a/stress.json"
check "stress.json says where the rates explode" python3 -c "
import json, sys
j = json.load(open('$tmp/a/stress.json'))
h = j['highest_rates']['wrong_fraction']
top = max(l['wrong_fraction'] for c in j['cases'] for l in c['lights'])
sys.exit(0 if h['rate'] == top and h['case'] in [c['name'] for c in j['cases']] else 1)"
check "report.html has a row per case" test "$(grep -o '<small>canonical: ' "$tmp/a/report.html" | wc -l)" -eq 6
check "report.html embeds the class maps" grep -q 'data:image/png;base64,' "$tmp/a/report.html"
check "junit has an oracle testcase per case" test "$(grep -c 'name="oracle invariant"' "$tmp/a.xml")" -eq 6
if require_tool xmllint xmllint; then
    junit_ok() { xmllint --noout --schema "$src/tests/cli/junit.xsd" "$1" 2>"$tmp/xmllint.log"; }
    check "junit validates against the schema" junit_ok "$tmp/a.xml"
fi

# world_float32 far from the origin: the far case's verdict changes, the oracle's does not.
run stress --out "$tmp/w" --cases far_1e8 --preset d3d12-textbook --set precision=world_float32 -q
check "world_float32 exits 0" test "$rc" -eq 0
check "world_float32 records the key" grep -q '"precision": "world_float32"' "$tmp/w/stress.json"
check "world_float32 loses coverage at 1e8 m" python3 -c "
import json, sys
c = json.load(open('$tmp/w/stress.json'))['cases'][0]
sys.exit(0 if c['lights'][0]['pixels']['coverage_mismatch'] > 100 and c['oracle_invariant'] else 1)"

# A gate over the suite: a failed check exits 1 and names the case, with every file written.
echo '{"checks": [{"metric": "rates.acne", "max": 0.0}]}' >"$tmp/gate.json"
run stress --out "$tmp/g" --cases contact_wedge_1deg --preset no-bias --gate "$tmp/gate.json" -q
check "failed gate exits 1" test "$rc" -eq 1
check "failed gate names the case" grep -q "case contact_wedge_1deg: light 0: rates.acne = " <<<"$err"
check "failed gate still writes stress.json" test -s "$tmp/g/stress.json"

# Bad input: exit 2, named, nothing written.
run stress --out "$tmp/b1" --cases far_1e9
check "unknown case exits 2" test "$rc" -eq 2
check "unknown case named" grep -q 'unknown case "far_1e9"' <<<"$err"
check "unknown case writes nothing" test ! -e "$tmp/b1"
echo '{"checks": [{"metric": "rates.acne", "max": 0.1, "light": 0}]}' >"$tmp/bad_gate.json"
run stress --out "$tmp/b2" --cases far_1e5 --gate "$tmp/bad_gate.json"
check "per-light gate exits 2" test "$rc" -eq 2
check "per-light gate named" grep -q 'bad_gate.json: checks\[0\].light' <<<"$err"
check "per-light gate writes nothing" test ! -e "$tmp/b2"
run stress --out "$tmp/b3" --cases far_1e5 --set precision=double
check "bad precision exits 2" test "$rc" -eq 2
check "bad precision named" grep -q 'precision: "double" is not one of "camera_relative", "world_float32"' <<<"$err"
run stress --out "$tmp/b4" --cases spot_179 --preset pcss
check "pcss on the suite's punctual lights exits 2" test "$rc" -eq 2
check "pcss refusal names the case" grep -q 'spot_179' <<<"$err"
finish
