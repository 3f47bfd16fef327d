#!/usr/bin/env bash
# penumbra tune end to end: the files, technique.json accepted by validate, hold-out scenarios,
# determinism across thread counts, --gate, per-light bias and --shared-bias, "keeps the start",
# and bad input (exit 2 naming it, nothing written).
# Usage: tune_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"
cp "$src/data/default/scene.glb" "$tmp/"
sed -e 's/"width": 1280/"width": 240/' -e 's/"height": 720/"height": 136/' \
    -e 's#"scene.glb"#"'"$tmp"'/scene.glb"#' "$src/data/default/scenario.json" >"$tmp/a.json"
sed 's/"eye": \[4.5, 4.0, 9.0\]/"eye": [-6.0, 5.0, 6.0]/' "$tmp/a.json" >"$tmp/b.json"
small=(--set resolution=512 --budget 14)

run tune "$tmp/a.json" --out "$tmp/t1" "${small[@]}" --holdout "$tmp/b.json" --threads 1
check "tune exits 0" test "$rc" -eq 0
for f in technique.json tune.json pareto.csv pareto.svg pareto.png report.html; do
    check "tune writes $f" test -s "$tmp/t1/$f"
done
check "tune.json has every evaluation" python3 -c "
import json, sys; j = json.load(open('$tmp/t1/tune.json'))
assert j['mode'] == 'per_light' and len(j['lights']) == 3 and j['start_evaluation'] == 0
assert all(1 <= len(l['evaluations']) <= 14 for l in j['lights'])
assert j['evaluations'] and j['front'] and j['holdout'] and j['revalidation']
assert j['recommendation']['units'][0]['d3d12']['DepthBias_D24'] >= 0"
check "technique.json carries each light's bias" python3 -c "
import json; t = json.load(open('$tmp/t1/technique.json'))
assert len(t['lights']) == 3 and all('constant' in l['bias'] and 'slope' in l['bias'] for l in t['lights'])"
check "no light re-validates worse than the start" python3 -c "
import json; j = json.load(open('$tmp/t1/tune.json'))
for b, a in zip(j['revalidation'][0]['before'], j['revalidation'][0]['after']):
    assert a['visible_bias_error']['sum'] <= b['visible_bias_error']['sum'] + 1e-12, (a, b)
    assert a['perceptual']['mean'] <= b['perceptual']['mean'] + 1e-12, (a, b)"
check "pareto.csv has a row per evaluation of each light" test "$(($(wc -l <"$tmp/t1/pareto.csv") - 1))" -eq \
    "$(python3 -c "import json; print(sum(len(l['evaluations']) for l in json.load(open('$tmp/t1/tune.json'))['lights']))")"
check "the terminal shows the hold-out result" grep -q "hold-out" "$tmp/stdout"
check "report.html renders cleanly in Chromium" html_check "$tmp/t1/report.html"
check "the plot renders in Chromium" timeout 120 chromium --headless --no-sandbox --disable-gpu \
    --screenshot="$tmp/plot.png" --window-size=720,480 "file://$tmp/t1/pareto.svg" 2>/dev/null

run validate "$tmp/a.json" --out "$tmp/v1" --technique "$tmp/t1/technique.json" -q
check "validate accepts technique.json as it is" test "$rc" -eq 0

# Deterministic: the same evaluations and recommendation with 2 threads.
run tune "$tmp/a.json" --out "$tmp/t2" "${small[@]}" --holdout "$tmp/b.json" --threads 2 -q
check "second run exits 0" test "$rc" -eq 0
check "same recommendation with 1 and 2 threads" cmp -s "$tmp/t1/technique.json" "$tmp/t2/technique.json"
check "same evaluations with 1 and 2 threads" python3 -c "
import json
a, b = (json.load(open(f'$tmp/{d}/tune.json'))['evaluations'] for d in ('t1', 't2'))
strip = lambda es: [{k: v for k, v in e.items() if k != 'seconds'} for e in es]
assert strip(a) == strip(b)"

# --shared-bias: one bias for every light, as before per-light tuning.
run tune "$tmp/a.json" --out "$tmp/ts" "${small[@]}" --shared-bias -q
check "--shared-bias exits 0" test "$rc" -eq 0
check "--shared-bias gives one bias, no per-light entries" python3 -c "
import json; j = json.load(open('$tmp/ts/tune.json')); t = json.load(open('$tmp/ts/technique.json'))
assert j['mode'] == 'shared_bias' and j['lights'] == [] and 'lights' not in t
assert 1 <= len(j['evaluations']) <= 14 and j['start_evaluation'] == 0"

# Never worse than the start: a cap of no visible acne at all costs more peter-panning than the
# start's acne on some light, which then keeps the start, and says so.
run tune "$tmp/a.json" --out "$tmp/tk" "${small[@]}" --preset d3d12-textbook --max-acne 0
check "a kept start exits 0" test "$rc" -eq 0
check "tune says it keeps the start" grep -q "keeps the start: " "$tmp/stdout"
check "tune.json says which light kept the start, and why" python3 -c "
import json; j = json.load(open('$tmp/tk/tune.json'))
kept = [l for l in j['lights'] if l['kept_start']]
assert kept and all(l['why'] for l in kept), j['lights']"
check "a kept light's bias is the start's" python3 -c "
import json; j = json.load(open('$tmp/tk/tune.json')); t = json.load(open('$tmp/tk/technique.json'))
for l in j['lights']:
    if l['kept_start']:
        b = t['lights'][l['light']]['bias']
        assert b['constant'] == 100000 and b['slope'] == 1.0, b"

# --gate: nothing feasible within one evaluation (the start, with no bias at all, leaves acne):
# exit 1.
run tune "$tmp/a.json" --out "$tmp/t3" --set resolution=512 --set bias.constant=0 --set bias.slope=0 --budget 1 \
    --gate -q
check "--gate without a feasible setting exits 1" test "$rc" -eq 1
check "--gate prints the best reachable" grep -q "best reachable" <<<"$err"

# A moment family: without --knobs its own knobs are searched, one value for every light.
run tune "$tmp/a.json" --out "$tmp/vsm" --set family=vsm --set filter.type=none --set resolution=256 --budget 3 -q
check "tune of a vsm technique exits 0" test "$rc" -eq 0
check "a vsm technique's knobs are its own" python3 -c "
import json; j = json.load(open('$tmp/vsm/tune.json'))
assert [k['name'] for k in j['knobs']] == ['min_variance', 'light_bleed'] and j['mode'] == 'shared_bias', j['knobs']
assert 'light_bleed' in json.load(open('$tmp/vsm/technique.json'))['vsm']"
run tune "$tmp/a.json" --out "$tmp/vsm2" --set family=vsm --set filter.type=none --knobs constant
check "a bias knob of a moment family exits 2" test "$rc" -eq 2
check "a bias knob of a moment family is named" grep -q -- '--knobs: constant is not a knob of technique family "vsm"' <<<"$err"

# Bad input: exit 2 naming it, before any work, nothing written.
run tune "$tmp/a.json" --out "$tmp/t4" --knobs constant,slop
check "unknown knob exits 2" test "$rc" -eq 2
check "unknown knob is named" grep -q -- '--knobs: unknown knob "slop"' <<<"$err"
check "unknown knob writes nothing" test ! -e "$tmp/t4"
run tune "$tmp/a.json" --out "$tmp/t5" --budget -3
check "negative budget exits 2" test "$rc" -eq 2
check "negative budget is named" grep -q -- '--budget: -3' <<<"$err"
check "negative budget writes nothing" test ! -e "$tmp/t5"
run tune "$tmp/a.json" --out "$tmp/t6" --minimize rates.peter_pan
check "unknown metric exits 2" test "$rc" -eq 2
check "unknown metric is named" grep -q -- '--minimize: no metric "rates.peter_pan"' <<<"$err"
check "unknown metric writes nothing" test ! -e "$tmp/t6"
run tune "$tmp/nope.json" --out "$tmp/t7"
check "missing scenario exits 2" test "$rc" -eq 2
# NaN and out-of-range numbers, and a budget beyond the documented bound (it reserved memory for
# every evaluation: exit 3 "out of memory"): exit 2 before any work, nothing written.
n=0
for opt in "--precision nan" "--tie nan" "--precision 2" "--max-acne nan" "--budget 1000000000" "--budget 10001"; do
    n=$((n + 1))
    run tune "$tmp/a.json" --out "$tmp/t8.$n" $opt
    check "$opt exits 2" test "$rc" -eq 2
    check "$opt is named" grep -q -- "${opt% *}: " <<<"$err"
    check "$opt writes nothing" test ! -e "$tmp/t8.$n"
done
check "--budget's bound is said" grep -q -- "--budget: 10001 evaluations; give 1 to 10000" <<<"$err"
run tune "$tmp/a.json" --out "$tmp/t8" --knobs $'constant,caf\xe9'
check "a non-UTF-8 --knobs exits 2" test "$rc" -eq 2
check "a non-UTF-8 --knobs is named" grep -q -- "--knobs: .* is not valid UTF-8" <<<"$err"
finish
