#!/usr/bin/env bash
# Issue #50's reproducers, one block per defect (its number in the comment): a hostile user's
# planted links, FIFOs, devices and look-alike files in the cache and the output folders, huge
# or crafted inputs. Each asserts the fixed behaviour: a clean exit 2 (or the documented code)
# and, where a decoy stands outside penumbra's own files, that its bytes are unchanged.
# Usage: files_under_attack.sh PENUMBRA SOURCE_DIR
source "$(dirname "$0")/harness.sh"
fail_detail() { echo "(rc=$rc) $(head -c 600 <<<"$err")"; }
run() {  # run ARGS... -> sets rc, err; a hang is a failure (rc 124)
    timeout 60 "$bin" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    err=$(head -c 4000 "$tmp/stderr")
}
# run_as_pid SETUP ARGS...: runs SETUP (a shell snippet that may use $BASHPID, the pid the
# penumbra process will have), then penumbra in that very process (exec keeps the pid).
run_as_pid() {
    local setup=$1
    shift
    (
        eval "$setup"
        exec "$bin" "$@"  # exec: penumbra keeps this pid (a hang is caught by ctest's TIMEOUT)
    ) >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    err=$(head -c 4000 "$tmp/stderr")
}
same_bytes() { cmp -s "$1" "$2"; }

cp "$src/data/default/scene.glb" "$tmp/"
sed -e 's/"width": 1280/"width": 32/' -e 's/"height": 720/"height": 18/' \
    -e 's#"scene.glb"#"'"$tmp"'/scene.glb"#' "$src/data/default/scenario.json" >"$tmp/s.json"
printf 'a decoy file outside penumbra'"'"'s own files\n' >"$tmp/decoy.orig"
decoy() { cp "$tmp/decoy.orig" "$tmp/decoy"; }
preset=(--preset d3d12-textbook)

# The scenario's cache key: from a first run's entry.
cache=$tmp/cache
run validate "$tmp/s.json" --out "$tmp/prime" --cache "$cache" "${preset[@]}"
check "a first run works" test "$rc" -eq 0
entry=$(cd "$cache" && ls oracle-*.bin | head -1)
key=${entry#oracle-}
key=${key%.bin}
check "the first run made an entry" test -n "$key"
fresh_cache() { rm -rf "$cache" && mkdir -p "$cache"; }

# 1: a symbolic link at the cache's temporary name is never written through.
fresh_cache
decoy
run_as_pid 'ln -s "$tmp/decoy" "$cache/.oracle-$key.tmp-$BASHPID"' \
    validate "$tmp/s.json" --out "$tmp/o1" --cache "$cache" "${preset[@]}"
check "1: validate exits 0" test "$rc" -eq 0
check "1: the file the link points to is unchanged" same_bytes "$tmp/decoy" "$tmp/decoy.orig"
check "1: the entry is a regular file, not the link" bash -c "test -f '$cache/$entry' && test ! -L '$cache/$entry'"

# 2: cache clear (and a store's clean-up) leave files, links and folders of a temporary's shape.
fresh_cache
decoy
dead=4194000
echo "the user's notes" >"$cache/.oracle-notes.tmp-$dead"
ln -s "$tmp/decoy" "$cache/.oracle-link.tmp-$dead"
mkdir "$cache/.oracle-folder.tmp-$dead"
echo "the user's own" >"$cache/.oracle-$key.bin.tmp-$dead-0123456789abcdef"
run cache clear --cache "$cache"
check "2: cache clear exits 0" test "$rc" -eq 0
check "2: a user's file of that shape stays" test -f "$cache/.oracle-notes.tmp-$dead"
check "2: a link of that shape stays" test -L "$cache/.oracle-link.tmp-$dead"
check "2: a folder of that shape stays" test -d "$cache/.oracle-folder.tmp-$dead"
check "2: a file without the entry header stays" test -f "$cache/.oracle-$key.bin.tmp-$dead-0123456789abcdef"
run validate "$tmp/s.json" --out "$tmp/o2" --cache "$cache" "${preset[@]}"
check "2: after a store, the user's file stays" test -f "$cache/.oracle-notes.tmp-$dead"
check "2: after a store, the link stays" test -L "$cache/.oracle-link.tmp-$dead"
check "2: the decoy is unchanged" same_bytes "$tmp/decoy" "$tmp/decoy.orig"

# 3: symbolic links at the output temporaries' old names in --out are never written through.
decoy
mkdir -p "$tmp/o3"
run_as_pid 'for f in report.json report.html oracle.json raster.json light0.classes.png; do
        ln -s "$tmp/decoy" "$tmp/o3/.$f.tmp-$BASHPID"; done' \
    validate "$tmp/s.json" --out "$tmp/o3" --cache "$cache" "${preset[@]}"
check "3: validate exits 0" test "$rc" -eq 0
check "3: the file the links point to is unchanged" same_bytes "$tmp/decoy" "$tmp/decoy.orig"
check "3: report.json is written" test -f "$tmp/o3/report.json" -a ! -L "$tmp/o3/report.json"
# ... and a link, FIFO or folder where an output goes is refused, not replaced.
decoy
mkdir -p "$tmp/o3b"
ln -s "$tmp/decoy" "$tmp/o3b/report.json"
run validate "$tmp/s.json" --out "$tmp/o3b" --cache "$cache" "${preset[@]}"
check "3: a symbolic link at report.json: exit 2" test "$rc" -eq 2
check "3: the message names it" grep -q "o3b/report.json: is a symbolic link" <<<"$err"
check "3: the link is left" test -L "$tmp/o3b/report.json"
check "3: no other output was moved in" test ! -e "$tmp/o3b/report.html"

# 4: init --force never replaces a FIFO (or a device).
mkfifo "$tmp/fifo.json"
run init "$tmp/scene.glb" --out "$tmp/fifo.json" --force
check "4: init --force on a FIFO: exit 2" test "$rc" -eq 2
check "4: the message says what it is" grep -q "fifo.json.*FIFO" <<<"$err"
check "4: the FIFO is still one" test -p "$tmp/fifo.json"
if [[ -c /dev/null ]]; then
    ln -s /dev/null "$tmp/devnull.json"
    run init "$tmp/scene.glb" --out "$tmp/devnull.json" --force
    check "4: init --force through a link to a device: exit 2" test "$rc" -eq 2
    check "4: /dev/null is still a device" test -c /dev/null
fi

# 5: a file (or an empty folder) named like an entry but not one is neither deleted nor replaced.
fresh_cache
echo "not an oracle" >"$cache/$entry"
cp "$cache/$entry" "$tmp/lookalike.orig"
run validate "$tmp/s.json" --out "$tmp/o5" --cache "$cache" "${preset[@]}"
check "5: validate exits 0" test "$rc" -eq 0
check "5: the look-alike is unchanged" same_bytes "$cache/$entry" "$tmp/lookalike.orig"
check "5: a warning names it" grep -q "$entry.*not one of penumbra's" <<<"$err"
fresh_cache
mkdir "$cache/$entry"
run validate "$tmp/s.json" --out "$tmp/o5b" --cache "$cache" "${preset[@]}"
check "5: with a folder there, validate exits 0" test "$rc" -eq 0
check "5: the folder stays" test -d "$cache/$entry"

# 6: diff.html never embeds what a class map's symbolic link points to.
fresh_cache
run validate "$tmp/s.json" --out "$tmp/da" --cache "$cache" "${preset[@]}"
run validate "$tmp/s.json" --out "$tmp/db" --cache "$cache" --preset no-bias
echo "secret bytes that must stay out of the page" >"$tmp/secret.txt"
rm "$tmp/db/light0.classes.png"
ln -s "$tmp/secret.txt" "$tmp/db/light0.classes.png"
run diff "$tmp/da" "$tmp/db" --out "$tmp/d6"
check "6: diff runs" test "$rc" -eq 0 -o "$rc" -eq 1
secret64=$(base64 -w0 "$tmp/secret.txt" | head -c 40)
check "6: the link's target is not embedded" fails grep -q "$secret64" "$tmp/d6/diff.html"
check "6: the page says why" grep -q "symbolic link" "$tmp/d6/diff.html"

# 7: strict JSON is linear: a 6 MB technique file of objects is refused (an unknown key) at once.
python3 -c "
import json
print(json.dumps({'preset': 'd3d12-textbook', 'junk': [{'a': i, 'b': [i]} for i in range(300000)]}))" >"$tmp/big.json"
start=$(date +%s)
run validate "$tmp/s.json" --out "$tmp/o7" --cache "$cache" --technique "$tmp/big.json"
check "7: a 6 MB technique file: exit 2" test "$rc" -eq 2
check "7: ... naming the unknown key" grep -q "junk" <<<"$err"
check "7: ... in under 20 s" test $(($(date +%s) - start)) -lt 20

# 8: a damaged entry whose header claims a huge frame allocates nothing and is removed.
fresh_cache
python3 -c "
import struct, sys
key = sys.argv[2].encode()
head = b'PNBORCL2' + key + struct.pack('<iiI', 16384, 16384, 4000) + struct.pack('<ddd', 0, 0, 0) + struct.pack('<Q', 2)
open(sys.argv[1], 'wb').write(head + b'{}')" "$cache/$entry" "$key"
(
    ulimit -v 4000000
    exec timeout 60 "$bin" validate "$tmp/s.json" --out "$tmp/o8" --cache "$cache" "${preset[@]}"
) >"$tmp/stdout" 2>"$tmp/stderr"
rc=$?
err=$(head -c 4000 "$tmp/stderr")
check "8: under a 4 GB limit, validate exits 0" test "$rc" -eq 0
check "8: the warning names the entry" grep -q "$entry" <<<"$err"
check "8: the entry was replaced by a good one" test "$(stat -c %s "$cache/$entry")" -gt 1000

# 9: a FIFO at an entry's path does not block.
fresh_cache
mkfifo "$cache/$entry"
run validate "$tmp/s.json" --out "$tmp/o9" --cache "$cache" "${preset[@]}"
check "9: validate exits 0 (no hang)" test "$rc" -eq 0
check "9: the FIFO stays" test -p "$cache/$entry"
fresh_cache

# 11: a long camera path at a large image is refused up front, with the estimate.
python3 - "$tmp/s.json" "$tmp/path.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["image"] = {"width": 2048, "height": 2048}
cam = s.pop("camera")
other = dict(cam, eye=[-4.5, 4.0, 9.0])
s["camera_path"] = {"frames": 10000, "keys": [cam, other]}
json.dump(s, open(sys.argv[2], "w"))
PY
run validate "$tmp/path.json" --out "$tmp/o11" --cache "$cache" "${preset[@]}"
check "11: a 10000-frame 2048^2 path: exit 2" test "$rc" -eq 2
check "11: ... with the estimate in hours" grep -q "camera_path: 10000 frames.* h" <<<"$err"
check "11: nothing in --out" test ! -e "$tmp/o11"

# 13: units refuses overflowing results and keys given twice.
run units "$tmp/s.json" --from bevy --to godot shadow_depth_bias=1e308 shadow_normal_bias=1e308
check "13: units with 1e308: exit 2" test "$rc" -eq 2
check "13: ... saying it overflows" grep -q "not a finite number" <<<"$err"
check "13: ... and printing no inf" fails grep -q "inf" "$tmp/stdout"
run units "$tmp/s.json" --from bevy --to three shadow_depth_bias=0.02 shadow_depth_bias=0.5
check "13: a key given twice: exit 2" test "$rc" -eq 2
check "13: ... naming it" grep -q "shadow_depth_bias.*given twice" <<<"$err"

# 14: diff refuses a report whose light indices are swapped or repeated.
python3 - "$tmp/db/report.json" "$tmp/dc/report.json" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
r["lights"][0]["index"], r["lights"][1]["index"] = 1, 0
os.makedirs(os.path.dirname(sys.argv[2]), exist_ok=True)
json.dump(r, open(sys.argv[2], "w"))
PY
run diff "$tmp/da" "$tmp/dc/report.json" --out "$tmp/d14"
check "14: swapped light indices: exit 2" test "$rc" -eq 2
check "14: ... naming the element" grep -q "lights\[0\].index" <<<"$err"
check "14: nothing in --out" test ! -e "$tmp/d14"

# 15: --cache-max must be whole bytes with a real suffix.
for size in 0.5 1iB; do
    run cache list --cache "$cache" --cache-max "$size"
    check "15: --cache-max $size: exit 2" test "$rc" -eq 2
    PENUMBRA_CACHE_MAX=$size run validate "$tmp/s.json" --out "$tmp/o15" --cache "$cache" "${preset[@]}"
    check "15: PENUMBRA_CACHE_MAX=$size: exit 2" test "$rc" -eq 2
done
run cache list --cache "$cache" --cache-max 1.5G
check "15: --cache-max 1.5G still works" test "$rc" -eq 0

# 16: cascades.max_distance below znear is refused as the technique is read, naming the file.
echo '{"preset": "unity-urp", "cascades": {"max_distance": 0.05}}' >"$tmp/near.json"
start=$(date +%s)
run validate "$tmp/s.json" --out "$tmp/o16" --cache "$cache" --technique "$tmp/near.json"
check "16: max_distance below znear: exit 2" test "$rc" -eq 2
check "16: ... naming the file and key" grep -q "near.json: cascades.max_distance" <<<"$err"
check "16: nothing in --out" test ! -e "$tmp/o16"

# 17: tune --units does not suggest an option tune does not have.
python3 - "$tmp/s.json" "$tmp/edge.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["lights"] = [{"type": "directional", "direction": [1.0, -0.0001, 0.0]}]
json.dump(s, open(sys.argv[2], "w"))
PY
run tune "$tmp/edge.json" --out "$tmp/o17" --units bevy --budget 2 "${preset[@]}"
check "17: tune --units on an edge-on plane: exit 2" test "$rc" -eq 2
check "17: ... without suggesting --angle-deg" fails grep -q -- "--angle-deg" <<<"$err"

# 18: --light -1, --set family=null.
run units "$tmp/s.json" --light -1 --from bevy --to three
check "18: --light -1: exit 2" test "$rc" -eq 2
check "18: ... not shown as a huge number" fails grep -q "18446744073709551615" <<<"$err"
run validate "$tmp/s.json" --out "$tmp/o18" --cache "$cache" "${preset[@]}" --set family=null
check "18: --set family=null: exit 2" test "$rc" -eq 2
check "18: ... saying null is refused" grep -q "family=null: null" <<<"$err"
check "18: nothing in --out" test ! -e "$tmp/o18"

finish
