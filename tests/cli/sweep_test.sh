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
    '^resolution,filter.type,wrong_fraction,mae,rates_visible.acne,rates_visible.peter_panning,rates_visible.aliasing,rates_visible.false_shadow,rates_visible.false_lit,rates_visible.light_bleeding,rates.acne,rates.peter_panning,rates.aliasing,rates.false_shadow,rates.false_lit,rates.light_bleeding,perceptual.mean,production_ms,diagnostic_ms' \
    "$tmp/one/sweep.csv"
check "sweep.csv has a row per configuration" test "$(wc -l <"$tmp/one/sweep.csv")" -eq 7
check "GPU times are measured" python3 -c "
import csv; rows = list(csv.DictReader(open('$tmp/one/sweep.csv')))
assert all(float(r['production_ms']) > 0 and float(r['diagnostic_ms']) > 0 for r in rows)"
check "sweep.json carries the device and repeats" python3 -c "
import json; j = json.load(open('$tmp/one/sweep.json')); assert j['device']['name'] and j['repeat'] == 2
assert len(j['configurations'][0]['production_ms']) == 2"
check "sweep.json names the scorer and the clocks, without a per-run calibration (shards must merge)" python3 -c "
import json; d = json.load(open('$tmp/one/sweep.json'))['device']
assert d['scorer'] in ('cpu', 'gpu') and d['timestamps']['period_ns'] > 0 and 'calibration' in d['timestamps']
assert 'calibration_deviation_ns' not in d['timestamps']"
check "sweep.json carries setup_s and the sweep's fingerprint" python3 -c "
import json; j = json.load(open('$tmp/one/sweep.json')); assert j['setup_s'] > 0 and len(j['fingerprint']) == 32"
check "report.html renders cleanly in Chromium" html_check "$tmp/one/report.html"
check "the plot renders in Chromium" timeout 120 chromium --headless --no-sandbox --disable-gpu \
    --screenshot="$tmp/plot.png" --window-size=900,560 "file://$tmp/one/pareto.svg" 2>/dev/null

# Shards: the cache is shared read-only once the oracle is in it.
chmod -R a-w "$tmp/cache"
verdict() {  # the verdict columns of a sweep.csv (all but the four timing columns)
    cut -d, -f1-11 "$1"
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
# Shards of another sweep (another tolerance; the same keys and count) are refused naming both
# folders; the same scenario by a relative path is the same sweep.
run sweep "$tmp/a.json" --out "$tmp/tol" "${vary[@]}" --shard 2/2 --tolerance 0.02
check "a shard with another tolerance runs" test "$rc" -eq 0
run merge "$tmp/s2-1" "$tmp/tol" --out "$tmp/m-tol"
check "shards of different sweeps exit 2" test "$rc" -eq 2
check "shards of different sweeps are named, both" grep -qF "$tmp/s2-1 and $tmp/tol: shards of different sweeps" <<<"$err"
check "shards of different sweeps write nothing" test ! -e "$tmp/m-tol"
(cd "$tmp" && "$bin" sweep a.json --out rel "${vary[@]}" --shard 2/2 >/dev/null 2>&1)
run merge "$tmp/s2-1" "$tmp/rel" --out "$tmp/m-rel" -q
check "the scenario by a relative and by an absolute path merges" test "$rc" -eq 0
check "... equal to one run" cmp -s <(verdict "$tmp/one/sweep.csv") <(verdict "$tmp/m-rel/sweep.csv")
run merge "$tmp/s2-1" "$tmp/s2-2" --out "$tmp/s2-2"
check "merge --out a shard folder exits 2" test "$rc" -eq 2
check "merge --out a shard folder is named" grep -qF -- "--out $tmp/s2-2 is one of the shard folders" <<<"$err"
check "merge --out a shard folder leaves the shard alone" test "$(ls -A "$tmp/s2-2" | wc -l)" -eq 5
chmod -R u+w "$tmp/cache"

# Damaged shards: exit 2 naming the folder and the JSON path (or sweep.csv's line), no --out
# folder and no temporary file left. One run's folder holds configurations 0 to 5 (total 6).
damaged() {  # damaged NAME PYTHON: a copy of one/ with sweep.json edited by PYTHON (on j)
    cp -r "$tmp/one" "$tmp/$1"
    python3 -c "
import json; p = '$tmp/$1/sweep.json'; j = json.load(open(p))
$2
json.dump(j, open(p, 'w'))"
}
run merge "$tmp/one" --out "$tmp/m-one" -q
check "one folder whose last configuration is total - 1 merges" test "$rc" -eq 0
damaged d-values "j['configurations'][0]['values'].append('x')"
damaged d-columns "j['columns'] = []"
damaged d-index "j['configurations'][5]['index'] = 6"
damaged d-fraction "j['configurations'][1]['verdict']['rates.acne'] = -0.5"
damaged d-time "j['configurations'][2]['production_ms'][1] = -3"
damaged d-fingerprint "del j['fingerprint']"
cp -r "$tmp/one" "$tmp/d-csv"
python3 -c "
p = '$tmp/d-csv/sweep.csv'; l = open(p).read().split('\n'); l[2], l[3] = l[3], l[2]; open(p, 'w').write('\n'.join(l))"
for d in "d-values:json: configurations[0].values" "d-columns:json: columns" \
    "d-index:json: configurations[5].index" "d-fraction:json: configurations[1].verdict.rates.acne" \
    "d-time:json: configurations[2].production_ms[1]" "d-fingerprint:json: fingerprint" "d-csv:csv: line 3"; do
    name=${d%%:*}
    mkdir -p "$tmp/out-$name"
    run merge "$tmp/$name" --out "$tmp/out-$name/m"
    check "merge of a damaged shard ($name) exits 2" test "$rc" -eq 2
    check "the damage is named ($name)" grep -qF "$tmp/$name/sweep.${d#*:}" <<<"$err"
    check "merge of a damaged shard writes nothing ($name)" test -z "$(ls -A "$tmp/out-$name")"
done

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
run sweep "$tmp/a.json" --out "$tmp/b5" --vary $'preset=caf\xe9'
check "a --vary value that is not UTF-8 exits 2" test "$rc" -eq 2
check "a --vary value that is not UTF-8 is named" grep -qF 'preset=caf\xE9' <<<"$err"
run sweep "$tmp/a.json" --out "$tmp/b6" --vary bias.slope=5 --vary 'bias={"constant":1}'
check "overlapping --vary keys exit 2" test "$rc" -eq 2
check "overlapping --vary keys are named, both" grep -qF -- "--vary bias.slope and --vary bias:" <<<"$err"
thousand=$(seq -s, 1 1000)
run sweep "$tmp/a.json" --out "$tmp/b7" --vary bias.constant=$thousand --vary bias.slope=$thousand
check "a 10^6-configuration product exits 2" test "$rc" -eq 2
check "the product is named" grep -qF "bias.constant (1000 values) x bias.slope (1000 values) gives 1000000" <<<"$err"
run sweep "$tmp/a.json" --out "$tmp/b8" --vary resolution=256 --repeat 1000000000
check "--repeat 1000000000 exits 2" test "$rc" -eq 2
python3 -c "import json; json.dump(['d3d12-textbook'] * 200000, open('$tmp/many.json', 'w'))"
run sweep "$tmp/a.json" --out "$tmp/b9" --configs "$tmp/many.json"
check "a 200,000-entry --configs exits 2" test "$rc" -eq 2
check "the --configs count is named" grep -qF "200000 configurations" <<<"$err"
python3 -c "import json; json.dump(['d3d12-textbook'] * 1000000, open('$tmp/million.json', 'w'))"
run sweep "$tmp/a.json" --out "$tmp/b9" --configs "$tmp/million.json"
check "an 18 MB --configs is refused by its size before it is read" \
    grep -qF "byte limit of a sweep configuration list file" <<<"$err"
run sweep "$tmp/a.json" --out "$tmp/b10" --vary bias.constant=$(seq -s, 1 100) --vary bias.slope=$(seq -s, 1 100) \
    --repeat 100
check "a run beyond the time limit exits 2" test "$rc" -eq 2
check "a run beyond the time limit is named" grep -qF "10000 of 10000 configurations in this run x (1 + 2 x 100" <<<"$err"
check "a run beyond the time limit suggests --shard" grep -qF -- "--shard K/N, N >= " <<<"$err"
check "bad input traces no oracle" test ! -e "$tmp/cache2"
for d in b1 b2 b3 b4 b5 b6 b7 b8 b9 b10; do check "bad input writes nothing ($d)" test ! -e "$tmp/$d"; done
# One reading of the rates (#53): for a one-light run, the terminal's line, report.json,
# report.html's class table, sweep.csv and diff.json give the same visible rate per class (the
# class map's legend is drawn from the same score into its PNG).
python3 -c "
import json
s = json.load(open('$tmp/a.json'))
s['lights'] = s['lights'][:1]
json.dump(s, open('$tmp/sun.json', 'w'))"
run validate "$tmp/sun.json" --out "$tmp/r1" --preset d3d12-textbook --cache "$tmp/cache1"
cp "$tmp/stdout" "$tmp/r1.stdout"
echo '["d3d12-textbook"]' >"$tmp/one.json"
run sweep "$tmp/sun.json" --out "$tmp/s1" --configs "$tmp/one.json" --repeat 1 -q --cache "$tmp/cache1"
run diff "$tmp/r1" "$tmp/r1" --out "$tmp/d1"
check "the terminal, report.json, report.html, sweep.csv and diff agree on the visible rates" python3 - \
    "$tmp/r1.stdout" "$tmp/r1/report.json" "$tmp/r1/report.html" "$tmp/s1/sweep.csv" "$tmp/d1/diff.json" <<'PY'
import csv, json, re, sys
line, report, html, sweep, diff = sys.argv[1:]
light = json.load(open(report))["lights"][0]
visible = light["rates_visible"]
terminal = dict(re.findall(r"(\w+) ([0-9.]+)% \([0-9.]+%\)", open(line).read()))
page = open(html).read()
page = page[page.index('id="light-0"'):]
row = csv.DictReader(open(sweep)).__next__()
d = json.load(open(diff))["lights"][0]["a"]["rates_visible"]
for cls, rate in visible.items():
    if cls in terminal:
        assert abs(float(terminal[cls]) - 100 * rate) <= 5e-4, (cls, terminal[cls], rate)
    m = re.search(r"</span>%s</td><td>\d+</td><td>([0-9.]+)%%</td>" % cls, page)
    assert m and abs(float(m.group(1)) - 100 * rate) <= 5e-5, (cls, m and m.group(1), rate)
    assert abs(float(row["rates_visible." + cls]) - rate) <= 1e-9, (cls, row["rates_visible." + cls], rate)
    assert abs(d[cls] - rate) <= 1e-12, (cls, d[cls], rate)
assert sum(visible.values()) > 0, visible
PY
# A preset name in --configs applies over the starting technique (its --set keys stay).
echo '["camera-frustum-article"]' >"$tmp/presets.json"
run sweep "$tmp/a.json" --out "$tmp/c1" --configs "$tmp/presets.json" --set resolution=256 --repeat 1 -q
check "--configs with a preset name runs" test "$rc" -eq 0
check "--configs' preset keeps --set resolution=256" python3 -c "
import json; t = json.load(open('$tmp/c1/sweep.json'))['configurations'][0]['technique']
assert t['resolution'] == 256 and t['preset'] == 'camera-frustum-article' and t['depth_format'] == 'd32', t"
finish
