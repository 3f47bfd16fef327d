#!/usr/bin/env bash
# validate over a scenario's camera_path (issue #34): a bad path is exit 2 naming the key and
# writes nothing; a good one writes flicker.exr, oracle.json says the BVH was built once, and
# report.json has each light's temporal verdict. Usage: camera_path_test.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc $rc: $err)"; }

cp "$src/data/default/scene.glb" "$tmp/"
key() {  # key EYE_X YFOV_DEG
    echo "{\"type\": \"perspective\", \"eye\": [$1, 2, 5], \"target\": [$1, 0, 0], \"yfov_deg\": $2, \"znear\": 0.1, \"zfar\": 100}"
}
scenario() {  # scenario FRAMES KEY... -> stdout
    local frames=$1
    shift
    local keys
    keys=$(IFS=,; echo "$*")
    cat <<JSON
{"scene": "scene.glb", "image": {"width": 64, "height": 48},
 "camera_path": {"frames": $frames, "keys": [$keys]},
 "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}]}
JSON
}

# A bad key: exit 2 naming its JSON path, before any work; nothing written, an existing folder untouched.
scenario 4 "$(key 0 45)" "$(key 1 0)" >"$tmp/bad.json"
PENUMBRA_CACHE_DIR="$tmp/cache" run validate "$tmp/bad.json" --out "$tmp/v1"
check "a bad camera_path key exits 2" test "$rc" -eq 2
check "the message names the key path" grep -q -F 'bad.json: camera_path.keys[1].yfov_deg: expected a field of view' <<<"$err"
check "a bad camera_path writes nothing" test ! -e "$tmp/v1"
check "a bad camera_path traces nothing" test ! -e "$tmp/cache"
mkdir -p "$tmp/v2" && echo keep >"$tmp/v2/keep.txt"
run validate "$tmp/bad.json" --out "$tmp/v2"
check "a bad camera_path leaves an existing folder as it was" test "$(ls -A "$tmp/v2")" = "keep.txt"
scenario 1 "$(key 0 45)" >"$tmp/one.json"
run validate "$tmp/one.json" --out "$tmp/v3"
check "one frame exits 2" test "$rc" -eq 2
check "one frame names camera_path.frames" grep -q -F 'one.json: camera_path.frames: expected an integer in [2, 10000]' <<<"$err"
check "one frame writes nothing" test ! -e "$tmp/v3"

# A good path: every frame judged, one BVH.
scenario 3 "$(key 0 45)" "$(key 0.5 45)" >"$tmp/path.json"
run validate "$tmp/path.json" --out "$tmp/ok" --set resolution=512
check "a camera path validates" test "$rc" -eq 0
check "flicker.exr is written" test -s "$tmp/ok/flicker.exr"
# JSON read with python3 (scripts/install-deps.sh installs it; jq is not a dependency).
jsonq() { python3 -c "import json, sys; j = json.load(open(sys.argv[1])); print(json.dumps(eval(sys.argv[2])))" "$@"; }
check "oracle.json: one BVH for every frame" test "$(jsonq "$tmp/ok/oracle.json" '[j["bvh_builds"], j["frames"], j["camera_path"]["bvh_builds"], len(j["camera_path"]["frame_s"])]')" = "[1, 3, 1, 3]"
check "report.json: the temporal verdict per light" test "$(jsonq "$tmp/ok/report.json" '[(t := j["lights"][0]["temporal"])["frames"], t["pairs"], len(t["per_frame"]), t["flicker_rate"] >= 0]')" = "[3, 2, 3, true]"
check "report.json: the pairs saw common points" test "$(jsonq "$tmp/ok/report.json" 'j["lights"][0]["temporal"]["points"] > 0')" = "true"
check "stdout tells the flicker" grep -q "flicker over 3 frames" "$tmp/stdout"

# Gates over a path: every frame is judged (the worst frame is named), temporal.* once over the
# path; a temporal check on a scenario without a path is exit 2.
echo '{"checks": [{"metric": "temporal.flicker_rate", "max": 1}, {"metric": "pixels.scored", "min": 1e9}]}' >"$tmp/gate.json"
run validate "$tmp/path.json" --out "$tmp/gated" --set resolution=512 --gate "$tmp/gate.json"
check "a failing check over a path exits 1" test "$rc" -eq 1
check "report.json: the worst frame named, flicker judged over the path" test "$(jsonq "$tmp/gated/report.json" '[[c["metric"], c["passed"], "frame" in c] for c in j["gate"]["checks"]]')" = '[["temporal.flicker_rate", true, false], ["pixels.scored", false, true]]'
check "the failure names its frame" grep -q -E 'pixels.scored = [0-9]+ < 1000000000 in frame [0-2]' <<<"$(cat "$tmp/stdout")$err"
cat >"$tmp/still.json" <<JSON
{"scene": "scene.glb", "image": {"width": 64, "height": 48}, "camera": $(key 0 45),
 "lights": [{"type": "directional", "direction": [-0.3, -1, -0.2]}]}
JSON
run validate "$tmp/still.json" --out "$tmp/still" --gate "$tmp/gate.json"
check "a temporal check without a camera path exits 2" test "$rc" -eq 2
check "it says why" grep -q -F 'temporal.flicker_rate is measured over a camera path only' <<<"$err"
check "and writes nothing" test ! -e "$tmp/still"

# Progress on a terminal (common/progress.h): the frames counted on one line rewritten in place,
# then cleared before the results; nothing of it where stderr is a pipe, or under -q on a terminal.
scenario 6 "$(key 0 45)" "$(key 1 45)" >"$tmp/tty.json"
on_terminal() {  # on_terminal OUT ARGS... -> what a terminal shows (stdout and stderr), on stdout
    python3 - "$bin" validate "$tmp/tty.json" --out "$@" <<'PY'
import os, pty, sys
pid, fd = pty.fork()
if pid == 0:
    os.execv(sys.argv[1], sys.argv[1:])
out = b""
while True:
    try:
        data = os.read(fd, 4096)
    except OSError:
        break
    if not data:
        break
    out += data
sys.stdout.write(out.decode(errors="replace"))
PY
}
shown=$(on_terminal "$tmp/tty1")
check "terminal: the frames are counted" grep -q $'validate: 3/6 frames judged' <<<"$shown"
check "terminal: the line is cleared before the results" grep -q $'\r\e\[Kvalidate: 64x48 px' <<<"$shown"
check "terminal: -q shows nothing" test -z "$(on_terminal "$tmp/tty2" -q)"
"$bin" validate "$tmp/tty.json" --out "$tmp/tty3" 2>"$tmp/piped.err" >/dev/null
check "a pipe: no progress line" fails grep -q 'frames judged' "$tmp/piped.err"
finish
