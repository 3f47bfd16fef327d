#!/usr/bin/env bash
# penumbra sweep and merge end to end: the files and their columns, shards merged equal one run
# on every verdict column (two and three shards), a read-only shared oracle cache, the plot and
# report in headless Chromium, and bad input (exit 2 naming it, before any work, nothing
# written). Usage: sweep_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"
sed -e 's/"width": 1280/"width": 240/' -e 's/"height": 720/"height": 136/' \
    -e 's#"scene.glb"#"'"$src"'/data/default/scene.glb"#' "$src/data/default/scenario.json" >"$tmp/a.json"
vary=(--vary resolution=256,512 --vary filter.type=none,pcf,poisson --repeat 2 -q)

run sweep "$tmp/a.json" --out "$tmp/one" "${vary[@]}"
check "sweep exits 0" test "$rc" -eq 0
for f in sweep.csv sweep.json pareto.svg pareto.png report.html; do check "sweep writes $f" test -s "$tmp/one/$f"; done
check "sweep.csv names the varied keys and the columns" grep -q \
    '^resolution,filter.type,wrong_fraction,mae,rates.acne,rates.peter_panning,rates.aliasing,rates.false_shadow,rates.false_lit,perceptual.mean,production_ms,diagnostic_ms' \
    "$tmp/one/sweep.csv"
check "sweep.csv has a row per configuration" test "$(wc -l <"$tmp/one/sweep.csv")" -eq 7
check "GPU times are measured" python3 -c "
import csv; rows = list(csv.DictReader(open('$tmp/one/sweep.csv')))
assert all(float(r['production_ms']) > 0 and float(r['diagnostic_ms']) > 0 for r in rows)"
check "sweep.json carries the device and repeats" python3 -c "
import json; j = json.load(open('$tmp/one/sweep.json')); assert j['device']['name'] and j['repeat'] == 2
assert len(j['configurations'][0]['production_ms']) == 2"
check "report.html renders cleanly in Chromium" html_check "$tmp/one/report.html"
check "the plot renders in Chromium" timeout 120 chromium --headless --no-sandbox --disable-gpu \
    --screenshot="$tmp/plot.png" --window-size=900,560 "file://$tmp/one/pareto.svg" 2>/dev/null

# Shards: the cache is shared read-only once the oracle is in it.
chmod -R a-w "$tmp/cache"
verdict() {  # the verdict columns of a sweep.csv (all but the four timing columns)
    cut -d, -f1-10 "$1"
}
for n in 2 3; do
    dirs=()
    for k in $(seq 1 $n); do
        run sweep "$tmp/a.json" --out "$tmp/s$n-$k" "${vary[@]}" --shard "$k/$n"
        check "shard $k/$n exits 0" test "$rc" -eq 0
        dirs+=("$tmp/s$n-$k")
    done
    run merge "${dirs[@]}" --out "$tmp/m$n" -q
    check "merge of $n shards exits 0" test "$rc" -eq 0
    check "$n merged shards equal one run on every verdict column" cmp -s <(verdict "$tmp/one/sweep.csv") \
        <(verdict "$tmp/m$n/sweep.csv")
    for f in sweep.json pareto.svg pareto.png report.html; do check "merge of $n writes $f" test -s "$tmp/m$n/$f"; done
done
chmod -R u+w "$tmp/cache"
run merge "$tmp/s3-1" "$tmp/s3-3" --out "$tmp/m-gap"
check "a missing shard exits 2" test "$rc" -eq 2
check "a missing shard is named" grep -q "configuration 1 is in no shard" <<<"$err"
check "a missing shard writes nothing" test ! -e "$tmp/m-gap"

# Bad input: exit 2 naming it before any work (no oracle traced), nothing written.
rm -rf "$tmp/cache2"
export PENUMBRA_CACHE_DIR="$tmp/cache2"
run sweep "$tmp/a.json" --out "$tmp/b1" --vary resolutoin=256,512
check "an unknown key exits 2" test "$rc" -eq 2
check "an unknown key is named" grep -q "resolutoin" <<<"$err"
run sweep "$tmp/a.json" --out "$tmp/b2" --vary resolution=256,abc
check "a bad value exits 2" test "$rc" -eq 2
check "a bad value is named" grep -q -- "--vary resolution=abc" <<<"$err"
run sweep "$tmp/a.json" --out "$tmp/b3" --vary resolution=256 --shard 3/2
check "a bad shard exits 2" test "$rc" -eq 2
run sweep "$tmp/a.json" --out "$tmp/b4"
check "no --vary and no --configs exits 2" test "$rc" -eq 2
check "bad input traces no oracle" test ! -e "$tmp/cache2"
for d in b1 b2 b3 b4; do check "bad input writes nothing ($d)" test ! -e "$tmp/$d"; done
finish
