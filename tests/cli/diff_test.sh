#!/usr/bin/env bash
# `penumbra diff` and `penumbra cache` end to end (issue #33): diff exits 1 when run B is worse and
# names the class, 0 between identical runs or when B is better, 2 for runs of other scenarios and
# for missing or malformed runs; the oracle cache keeps under its cap by dropping the least
# recently used entry, and `cache list|prune|clear` touch only the cache's own files.
# Usage: diff_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc) ${err:0:400}"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"

# The issue's case: data/default under two presets. Presets are explicit: the default technique
# may change.
run validate "$src/data/default/scenario.json" --preset d3d12-textbook --out "$tmp/textbook" -q
check "validate d3d12-textbook exits 0" test "$rc" -eq 0
run validate "$src/data/default/scenario.json" --preset diligent-tutorial13 --out "$tmp/diligent" -q
check "validate diligent-tutorial13 exits 0" test "$rc" -eq 0
run validate "$src/data/default/scenario.json" --preset d3d12-textbook --out "$tmp/textbook2" -q
check "report.json records the scenario's fingerprint" grep -q '"fingerprint"' "$tmp/textbook/report.json"

run diff "$tmp/textbook" "$tmp/diligent/report.json" --out "$tmp/d1"
check "diligent-tutorial13 after d3d12-textbook is worse: exit 1" test "$rc" -eq 1
check "the worse class is named: acne" grep -q "worse: light 0 (directional): acne visible rate" <<<"$err"
check "the table is printed" grep -q "^  acne " "$tmp/stdout"
check "diff writes diff.json" grep -q '"worse": true' "$tmp/d1/diff.json"
check "diff writes diff.html with both class maps" test "$(grep -o 'data:image/png' "$tmp/d1/diff.html" | wc -l)" -eq 6
if require_tool chromium chromium; then check "diff.html opens cleanly in a browser" html_check "$tmp/d1/diff.html"; fi
check "nothing but diff's files in --out" test "$(ls -A "$tmp/d1" | tr '\n' ' ')" = "diff.html diff.json "

run diff "$tmp/diligent" "$tmp/textbook"
check "d3d12-textbook after diligent-tutorial13 is better: exit 0" test "$rc" -eq 0
check "a better run is said not worse" grep -q "B is not worse than A" "$tmp/stdout"
run diff "$tmp/diligent" "$tmp/textbook" --gate-worse 0
check "with no tolerance the small rises of the better run are named: exit 1" test "$rc" -eq 1
check "... as peter-panning" grep -q "peter_panning visible rate" <<<"$err"

run diff "$tmp/textbook" "$tmp/textbook2/report.json" --out "$tmp/d2"
check "two identical runs: exit 0" test "$rc" -eq 0
check "two identical runs are said identical" grep -q "B is identical to A" "$tmp/stdout"
check "diff.json says identical" grep -q '"identical": true' "$tmp/d2/diff.json"

# Runs of different scenarios: exit 2 naming what differs, nothing written. Small copies of
# data/default and data/soft (same scene, camera and image; other lights).
for s in default soft; do
    sed -e 's/"width": 1280/"width": 160/' -e 's/"height": 720/"height": 90/' \
        -e "s#\"[./a-z]*scene.glb\"#\"$src/data/default/scene.glb\"#" "$src/data/$s/scenario.json" >"$tmp/$s.json"
    run validate "$tmp/$s.json" --out "$tmp/small-$s" -q
    check "validate small $s exits 0" test "$rc" -eq 0
done
run diff "$tmp/small-default" "$tmp/small-soft" --out "$tmp/d3"
check "other scenarios: exit 2" test "$rc" -eq 2
check "other scenarios: the lights are named" grep -q "different scenarios: the lights (their types or placement) differ" <<<"$err"
check "other scenarios: the camera and scene are not named" fails grep -q "camera\|scene (its" <<<"$err"
check "other scenarios: nothing written" test ! -e "$tmp/d3"
run diff "$tmp/textbook" "$tmp/small-default"
check "another image size: exit 2" test "$rc" -eq 2
check "another image size is named" grep -q "image 1280x720 against 160x90" <<<"$err"

# Missing and malformed runs: exit 2 naming the file and what is wrong.
run diff "$tmp/textbook" "$tmp/nowhere"
check "a missing run: exit 2" test "$rc" -eq 2
check "a missing run is named" grep -q "$tmp/nowhere: no such file or folder" <<<"$err"
mkdir -p "$tmp/empty"
run diff "$tmp/empty" "$tmp/textbook"
check "a folder without a report: exit 2" test "$rc" -eq 2
check "a folder without a report is named" grep -q "$tmp/empty: holds neither report.json nor stress.json" <<<"$err"
mkdir -p "$tmp/broken" "$tmp/cut"
echo '{"version": ' >"$tmp/broken/report.json"
run diff "$tmp/textbook" "$tmp/broken"
check "a malformed report.json: exit 2" test "$rc" -eq 2
check "a malformed report.json is named" grep -q "$tmp/broken/report.json" <<<"$err"
sed 's/"wrong_fraction"/"wrong_fractio"/' "$tmp/textbook/report.json" >"$tmp/cut/report.json"
run diff "$tmp/cut/report.json" "$tmp/textbook" --out "$tmp/d4"
check "a report.json without a key: exit 2" test "$rc" -eq 2
check "... naming the file and the key" grep -q "cut/report.json: lights\[0\].wrong_fraction: missing" <<<"$err"
check "... and writing nothing" test ! -e "$tmp/d4"
run diff "$tmp/textbook" "$tmp/diligent" --gate-worse 2
check "a tolerance above 1: exit 2" test "$rc" -eq 2

# Stress runs: paired by case and light, compared on all wrong pixels (stress.json has no visible counts).
run stress --out "$tmp/st1" -q --cases far_1e7,object_1cm --preset d3d12-textbook
run stress --out "$tmp/st2" -q --cases far_1e7,object_1cm --preset diligent-tutorial13
run diff "$tmp/st1" "$tmp/st2/stress.json" --out "$tmp/d5"
check "stress: diligent-tutorial13 after d3d12-textbook is worse: exit 1" test "$rc" -eq 1
check "stress: the case, light and class are named" grep -q "worse: object_1cm light 0 (directional): acne rate" <<<"$err"
check "stress: diff.html shows the cases' class maps" test "$(grep -o 'data:image/png' "$tmp/d5/diff.html" | wc -l)" -eq 6
run stress --out "$tmp/st3" -q --cases far_1e7,needles --preset d3d12-textbook
run diff "$tmp/st1" "$tmp/st3"
check "stress: other cases: exit 2" test "$rc" -eq 2
check "stress: other cases are named" grep -q "cases only in A: object_1cm; cases only in B: needles" <<<"$err"
run diff "$tmp/st1" "$tmp/textbook"
check "a stress run against a validate run: exit 2" test "$rc" -eq 2

run diff --help
check "diff --help lists its outputs" grep -q "diff.json" "$tmp/stdout"
check "diff --help has an example" grep -q "Example" "$tmp/stdout"
run cache --help
check "cache --help has an example" grep -q "Example" "$tmp/stdout"

# The cache: validate says where the oracle lives; list, prune, clear.
run validate "$tmp/default.json" --preset d3d12-textbook --out "$tmp/v1"
check "validate names the cached oracle and its size" grep -q "oracle cache: $tmp/cache/oracle-[0-9a-f]*.bin ([0-9.]* [KM]iB); the cache holds" "$tmp/stdout"
check "oracle.json gives the entry's size" grep -q '"total_bytes"' "$tmp/v1/oracle.json"
run cache list
check "cache list exits 0" test "$rc" -eq 0
check "cache list shows three entries" test "$(grep -c '^oracle-[0-9a-f]*.bin ' "$tmp/stdout")" -eq 3
check "cache list gives the total" grep -q "$tmp/cache: 3 entries, .* (cap 2.0 GiB)" "$tmp/stdout"

# Fill past the cap: the least recently used entry goes.
cache2="$tmp/cache2"
run validate "$tmp/default.json" --out "$tmp/c1" -q --cache "$cache2"
first=$(ls "$cache2"/oracle-*.bin)
touch -d '1 hour ago' "$first"
sed 's/"width": 160/"width": 150/' "$tmp/default.json" >"$tmp/default150.json"
run validate "$tmp/default150.json" --out "$tmp/c2" -q --cache "$cache2" --cache-max $(($(stat -c %s "$first") + 1))
check "a store past the cap exits 0" test "$rc" -eq 0
check "the least recently used entry went" test ! -e "$first"
check "the new entry stayed" test "$(ls "$cache2"/oracle-*.bin | wc -l)" -eq 1
echo "not penumbra's" >"$cache2/notes.txt"
printf 'not an entry' >"$cache2/oracle-0123456789abcdef0123456789abcdef.bin"
run cache prune --cache "$cache2" --cache-max 1K
check "cache prune exits 0" test "$rc" -eq 0
check "cache prune removes what exceeds the cap" grep -q "removed 1 entry" "$tmp/stdout"
run validate "$tmp/default.json" --out "$tmp/c3" -q --cache "$cache2"
PENUMBRA_CACHE_DIR="$cache2" run cache clear
check "cache clear exits 0" test "$rc" -eq 0
check "cache clear removes the entries" grep -q "removed 1 entry" "$tmp/stdout"
check "cache clear leaves other files" test -e "$cache2/notes.txt"
check "cache clear leaves a file named like an entry without its magic" test -e "$cache2/oracle-0123456789abcdef0123456789abcdef.bin"
PENUMBRA_CACHE_MAX=lots run validate "$tmp/default.json" --out "$tmp/c4" -q
check "a bad PENUMBRA_CACHE_MAX: exit 2" test "$rc" -eq 2
check "a bad PENUMBRA_CACHE_MAX is named" grep -q "PENUMBRA_CACHE_MAX lots: expected a size" <<<"$err"
check "a bad PENUMBRA_CACHE_MAX writes nothing" test ! -e "$tmp/c4"
run cache prune --cache-max 2X
check "a bad --cache-max: exit 2" test "$rc" -eq 2
run cache list --cache "$tmp/default.json"
check "a file as the cache folder: exit 2" test "$rc" -eq 2

finish
