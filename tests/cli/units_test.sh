#!/usr/bin/env bash
# `penumbra units` and `tune --units` end to end (issue #38, docs/units.md): a conversion and its
# way back give the values the user started from, three's bias is normalised depth of the map's
# range, --to penumbra prints the technique keys, bad engines, keys and values are exit 2 naming
# them, and tune --units three writes three's bias and normalBias into tune.json.
# Usage: units_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $(head -c 400 <<<"$err"))"; }
export PENUMBRA_CACHE_DIR="$tmp/cache"
scenario="$src/data/default/scenario.json"

run units "$scenario" --light 0 --from bevy --to three shadow_depth_bias=0.02 shadow_normal_bias=1.8 --json
check "units exits 0" test "$rc" -eq 0
cp "$tmp/stdout" "$tmp/b2t.json"
check "bevy -> three: bias is -0.02 m over the map's depth range, normalBias 1.8 sqrt(2) texels" python3 -c "
import json, math; j = json.load(open('$tmp/b2t.json'))
m = j['maps'][0]; v = m['values']
assert j['to'] == 'three' and len(j['maps']) == 1 and m['cascade'] is None, j
assert abs(v['bias'] + 0.02 / m['depth_range_m']) < 1e-12, v
assert abs(v['normalBias'] - 1.8 * math.sqrt(2) * m['texel_m']) < 1e-12, v
assert 0 < j['reference']['angle_deg'] < 89"

# A -> B -> A on the same map gives A's values back (1e-6 relative), for a few pairs.
roundtrip() {  # roundtrip A B KEY=VALUE...
    local a=$1 b=$2
    shift 2
    run units "$scenario" --from "$a" --to "$b" "$@" --json
    [[ $rc -eq 0 ]] || return 1
    local there
    there=$(python3 -c "
import json; v = json.load(open('$tmp/stdout'))['maps'][0]['values']
print(' '.join('%s=%r' % (k, x) for k, x in v.items()))")
    # shellcheck disable=SC2086
    run units "$scenario" --from "$b" --to "$a" $there --json
    [[ $rc -eq 0 ]] || return 1
    python3 -c "
import json, sys
back = json.load(open('$tmp/stdout'))['maps'][0]['values']
for kv in sys.argv[1:]:
    k, x = kv.split('=')
    assert abs(back[k] - float(x)) <= 1e-6 * abs(float(x)) + 1e-15, (k, x, back[k])" "$@"
}
check "bevy -> godot -> bevy" roundtrip bevy godot shadow_depth_bias=0.03 shadow_normal_bias=1.2
check "three -> filament -> three" roundtrip three filament bias=-0.0005 normalBias=0.02
check "unity-urp -> babylon -> unity-urp" roundtrip unity-urp babylon depth_bias=1.5 normal_bias=0.7
check "unreal -> bevy -> unreal" roundtrip unreal bevy ShadowBias=0.6 ShadowSlopeBias=0.4

run units "$scenario" --from bevy --to penumbra --json
check "--to penumbra gives the technique's bias object" python3 -c "
import json, math; b = json.load(open('$tmp/stdout'))['maps'][0]['values']
assert abs(b['normal_offset'] - 1.8 * math.sqrt(2)) < 1e-12 and b['world'] == 0.02 and b['constant'] == 0, b
assert b['caster']['normal_factor'] == 'none', b"
run units "$scenario" --from godot --to bevy --set family=cascaded --set cascades.count=3
check "a cascaded technique: one line per cascade" test "$(grep -c '^  cascade [0-2]:' "$tmp/stdout")" -eq 3
check "the text names the reference receiver" grep -q "reference receiver: .* deg" "$tmp/stdout"
run units "$scenario" --from bevy --to three --angle-deg 45 --json
check "--angle-deg sets the reference angle" python3 -c "
import json; j = json.load(open('$tmp/stdout')); assert j['reference']['angle_deg'] == 45 and j['reference']['source'] == '--angle-deg'"

run units "$scenario" --from ogre --to three
check "an unknown engine: exit 2 naming it" test "$rc" -eq 2 -a -n "$(grep 'no engine "ogre"' <<<"$err")"
run units "$scenario" --from bevy --to three shadow_bias=1
check "an unknown key: exit 2 naming it" test "$rc" -eq 2 -a -n "$(grep 'no key "shadow_bias"' <<<"$err")"
run units "$scenario" --from three --to bevy bias=nan
check "a bad value: exit 2 naming it" test "$rc" -eq 2 -a -n "$(grep 'bias=nan' <<<"$err")"
run units "$scenario" --from bevy --to godot --assume soft_shadow_filter_quality=fuzzy
check "a bad assumption: exit 2 naming it" test "$rc" -eq 2 -a -n "$(grep 'soft_shadow_filter_quality=fuzzy' <<<"$err")"
run units "$scenario" --from bevy --to three --light 7
check "a light the scenario lacks: exit 2" test "$rc" -eq 2 -a -n "$(grep -- '--light: 7' <<<"$err")"
run units "$scenario" --from bevy --to godot --angle-deg 0 shadow_normal_bias=1
check "a normal bias Godot cannot carry at 0 deg: exit 2" test "$rc" -eq 2 -a -n "$(grep 'godot cannot carry' <<<"$err")"

# tune --units three: three's parameters per light in tune.json and in the summary.
cp "$src/data/default/scene.glb" "$tmp/"
sed -e 's/"width": 1280/"width": 96/' -e 's/"height": 720/"height": 54/' \
    -e 's#"scene.glb"#"'"$tmp"'/scene.glb"#' "$scenario" >"$tmp/small.json"
run tune "$tmp/small.json" --out "$tmp/t" --set resolution=256 --budget 2 --units three
check "tune --units three exits 0" test "$rc" -eq 0
check "tune.json gives three's bias and normalBias per light" python3 -c "
import json; j = json.load(open('$tmp/t/tune.json'))
units = j['recommendation']['units']
assert len(units) == 3, units
for u in units:
    e = u['engine']
    assert e['name'] == 'three' and set(e['parameters']) == {'bias', 'normalBias'}, e
    assert 'reference_angle_deg' in e['assumptions'] and 'map' in e, e"
check "the summary prints three's parameters" grep -q "three: bias = " "$tmp/stdout"
run tune "$tmp/small.json" --out "$tmp/t2" --budget 2 --units ogre
check "tune --units with an unknown engine: exit 2, nothing written" test "$rc" -eq 2 -a ! -e "$tmp/t2"
# --from penumbra without values converts the technique's own bias (d3d12-textbook: constant
# 100000, slope 1), not zeros; zeros and cascades are said (issue #53).
run units "$scenario" --from penumbra --to three --json
check "--from penumbra, no values: the technique's bias" python3 -c '
import json, sys; j = json.loads(sys.stdin.read()); f = j["from"]
assert f["source"] == "technique" and f["values"]["constant"] == 100000 and f["values"]["slope"] == 1, f
assert j["maps"][0]["values"]["bias"] != 0, j["maps"]' <"$tmp/stdout"
run units "$scenario" --from penumbra --to three --json world=0.05
check "--from penumbra with values: those values, not the technique's" python3 -c '
import json, sys; j = json.loads(sys.stdin.read()); f = j["from"]
assert f["source"] == "arguments" and f["values"]["world"] == 0.05 and f["values"]["constant"] == 0, f' <"$tmp/stdout"
run units "$scenario" --from penumbra --to three --preset no-bias
check "all zeros are said" grep -q "note: every value converted is 0" "$tmp/stdout"
run units "$scenario" --from penumbra --to godot --preset godot
check "cascades are said" grep -q "note: 4 cascades, each with its own texel and depth range" "$tmp/stdout"
finish
