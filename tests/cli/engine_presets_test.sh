#!/usr/bin/env bash
# Every engine preset (docs/engines.md) validates data/default end to end at 240 x 136: exit 0,
# a report with a verdict for each of the three lights, and raster.json naming the preset.
# Usage: engine_presets_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"  # one oracle, traced once, for all nine
sed -e 's/"width": 1280/"width": 240/' -e 's/"height": 720/"height": 136/' \
    -e 's#"scene.glb"#"'"$src"'/data/default/scene.glb"#' "$src/data/default/scenario.json" >"$tmp/a.json"
for preset in bevy godot unity-urp unreal-csm three three-csm filament babylon babylon-csm; do
    run validate "$tmp/a.json" --out "$tmp/$preset" --preset "$preset" -q
    check "$preset: validate exits 0" test "$rc" -eq 0
    check "$preset: report.json has a verdict for each light" python3 -c "
import json, sys
r = json.load(open('$tmp/$preset/report.json'))
assert len(r['lights']) == 3, len(r['lights'])
for l in r['lights']:
    assert 0 <= l['wrong_fraction'] <= 1 and l['pixels']['scored'] > 0, l"
    check "$preset: raster.json names the preset" python3 -c "
import json
assert json.load(open('$tmp/$preset/raster.json'))['technique']['preset'] == '$preset'"
done
# A cascaded preset's report.html shows each cascade's range, texel and pixels, as report.json
# holds them (#49).
check "three-csm: report.html has a row per cascade of report.json, with its range and pixels" python3 -c "
import json, re
r = json.load(open('$tmp/three-csm/report.json'))
page = open('$tmp/three-csm/report.html').read()
cascades = r['lights'][0]['cascades']
start = page.index('<h3>cascades (%d)</h3>' % len(cascades))
table = page[start:page.index('</table>', start)]
rows = re.findall(r'<tr><td>(\d+)</td><td>([^<]*)</td><td>[^<]*</td><td>(\d+)</td>', table)
assert len(rows) == len(cascades), rows
for (index, depths, px), c in zip(rows, cascades):
    assert int(index) == c['index'] and int(px) == c['pixels']['scored'], (index, px, c)
    near, far = (float(x) for x in depths.split(' – '))
    assert abs(near - c['near_m']) <= 1e-3 * c['far_m'] and abs(far - c['far_m']) <= 1e-3 * c['far_m'], depths"
# --preset over a scenario's technique block: the block's keys and --set win over the preset's
# defaults, and the run says which it kept (stdout and report.json's preset_differences).
python3 -c "
import json
s = json.load(open('$tmp/a.json'))
s['technique'] = {'bias': {'constant': 3}}
json.dump(s, open('$tmp/block.json', 'w'))"
run validate "$tmp/block.json" --out "$tmp/kept" --preset three --set resolution=1024
check "--preset over a technique block: exit 0" test "$rc" -eq 0
check "... stdout names the kept keys with the preset's values" grep -q \
    "technique: preset three with 2 keys .*bias.constant 3.0 (preset: 0.0), resolution 1024 (preset: 512)" "$tmp/stdout"
check "... report.json's preset_differences holds them" python3 -c "
import json
d = json.load(open('$tmp/kept/report.json'))['preset_differences']
assert d == {'bias.constant': {'preset': 0.0, 'technique': 3.0}, 'resolution': {'preset': 512, 'technique': 1024}}, d"
run validate "$tmp/a.json" --out "$tmp/plain" --preset three
check "a preset alone prints no such line" fails grep -q "^technique: preset" "$tmp/stdout"
run validate "$tmp/a.json" --out "$tmp/bad" --preset unity
check "an engine's bare name is not a preset (exit 2, the presets listed)" test "$rc" -eq 2
check "the error lists unity-urp" grep -q '"unity-urp"' <<<"$err"
finish
