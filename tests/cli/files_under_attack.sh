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

# 3 (--junit): a link at --junit's name is refused before any work, as the final rename refuses it.
decoy
ln -sf "$tmp/decoy" "$tmp/junit-link.xml"
run validate "$tmp/s.json" --out "$tmp/o3j" --cache "$cache" "${preset[@]}" --junit "$tmp/junit-link.xml"
check "3: --junit at a symbolic link: exit 2" test "$rc" -eq 2
check "3: ... saying it is a link" grep -q "junit-link.xml: is a symbolic link" <<<"$err"
check "3: ... before any work (no --out)" test ! -e "$tmp/o3j"
check "3: ... and the file it points to unchanged" same_bytes "$tmp/decoy" "$tmp/decoy.orig"

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

# 7: strict JSON is linear: a 6 MB scenario of objects is refused (an unknown key) at once.
python3 -c "
import json, sys
s = json.load(open(sys.argv[1]))
s['junk'] = [{'a': i, 'b': [i]} for i in range(300000)]
print(json.dumps(s))" "$tmp/s.json" >"$tmp/big.json"
start=$(date +%s)
run validate "$tmp/big.json" --out "$tmp/o7" --cache "$cache" "${preset[@]}"
check "7: a 6 MB scenario: exit 2" test "$rc" -eq 2
check "7: ... naming the unknown key" grep -q "junk" <<<"$err"
check "7: ... in under 20 s" test $(($(date +%s) - start)) -lt 20
# Each kind of JSON file has its size: a 64 MiB scenario, technique or report is refused before
# a byte is read (sparse files: only the size is looked at); a scenario of small objects at its
# 16 MiB limit is parsed and refused for its unknown key.
truncate -s 64M "$tmp/huge.json"
start=$(date +%s)
run validate "$tmp/huge.json" --out "$tmp/o7b" --cache "$cache" "${preset[@]}"
check "7: a 64 MiB scenario: exit 2" test "$rc" -eq 2
check "7: ... naming the limit of a scenario file" grep -q "16777216 byte limit of a scenario file" <<<"$err"
run validate "$tmp/s.json" --out "$tmp/o7c" --cache "$cache" --technique "$tmp/huge.json"
check "7: a 64 MiB technique: exit 2, the limit of a technique file" grep -q "1048576 byte limit of a technique file" <<<"$err"
mkdir -p "$tmp/hugerun"
cp "$tmp/huge.json" "$tmp/hugerun/report.json"
run diff "$tmp/hugerun" "$tmp/hugerun" --out "$tmp/d7"
check "7: a 64 MiB report for diff: exit 2, the limit of a report file" grep -q "byte limit of a report file" <<<"$err"
check "7: ... at once" test $(($(date +%s) - start)) -lt 5
rm -f "$tmp/huge.json" "$tmp/hugerun/report.json"
python3 - "$tmp/s.json" "$tmp/big_scenario.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
text = json.dumps(s)[:-1] + ', "junk": ['
unit = '{"a":1,"b":[2]},'
n = (16 * 1024 * 1024 - len(text) - 2) // len(unit)
open(sys.argv[2], "w").write(text + unit * (n - 1) + unit[:-1] + "]}")
PY
start=$(date +%s)
run validate "$tmp/big_scenario.json" --out "$tmp/o7d" --cache "$cache" "${preset[@]}"
check "7: a 16 MiB scenario of small objects is parsed: exit 2 for its unknown key" grep -q "junk" <<<"$err"
check "7: ... in under 10 s (1.1 s on a quiet 2-core VM)" test $(($(date +%s) - start)) -lt 10
rm -f "$tmp/big_scenario.json"

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

# 10: diff.html embeds class maps within a total budget (256 MiB): 8 lights of 60 MB "maps"
# (sparse files that start like a PNG) on either side make a page of at most the budget.
python3 - "$tmp/da/report.json" "$tmp/d10" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
light = r["lights"][0]
r["lights"] = [dict(light, index=i) for i in range(8)]
for side in ("a", "b"):
    d = os.path.join(sys.argv[2], side)
    os.makedirs(d, exist_ok=True)
    json.dump(r, open(os.path.join(d, "report.json"), "w"))
    for i in range(8):
        with open(os.path.join(d, f"light{i}.classes.png"), "wb") as f:
            f.write(b"\x89PNG\r\n\x1a\n")
            f.truncate(60 << 20)
PY
run diff "$tmp/d10/a" "$tmp/d10/b" --out "$tmp/d10/out"
check "10: diff of 16 x 60 MB class maps runs" test "$rc" -eq 0
page=$(stat -c %s "$tmp/d10/out/diff.html" 2>/dev/null || echo 0)
check "10: the page stays within the budget (base64 of 256 MiB and the text)" \
    test "$page" -le $(((256 << 20) / 3 * 4 + (1 << 20)))
check "10: ... embeds what fits (four maps)" \
    test "$(grep -o 'data:image/png;base64' "$tmp/d10/out/diff.html" | wc -l)" -eq 4
check "10: ... and says why the rest is not there" \
    grep -q "budget for embedded images is spent" "$tmp/d10/out/diff.html"
rm -rf "${tmp:?}/d10"

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

# 12: a foreign entry with a valid checksum (another light count, or NaN truth) is a miss: the
# run traces afresh and gives the verdict a clean cache gives.
# rewrite_entry IN OUT KEY [nan]: IN's entry under KEY (its header's key replaced), with the
# first visibility value NaN when asked, and its XXH3-64 checksum made again (xxhsum -H3).
rewrite_entry() {
    python3 -c '
import math, struct, subprocess, sys
src, dst, key = sys.argv[1], sys.argv[2], sys.argv[3].encode()
b = bytearray(open(src, "rb").read())
b[8:40] = key
w, h, lights = struct.unpack_from("<iiI", b, 40)
info_len, = struct.unpack_from("<Q", b, 40 + 12 + 24)
if len(sys.argv) > 4:  # light 0 V follows the header, the info, A (floats) and prim (uint32s)
    struct.pack_into("<f", b, 40 + 12 + 24 + 8 + info_len + 8 * w * h, math.nan)
out = subprocess.run(["xxhsum", "-H3", "-"], input=bytes(b[8:-8]), capture_output=True, check=True).stdout.decode()
digest = out.split("=")[-1].strip() if "=" in out else out.split()[0]
b[-8:] = bytes.fromhex(digest)[::-1]  # the entry stores it little-endian
open(dst, "wb").write(bytes(b))' "$@"
}
python3 - "$tmp/s.json" "$tmp/one.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["lights"] = s["lights"][:1]
json.dump(s, open(sys.argv[2], "w"))
PY
fresh_cache
run validate "$tmp/one.json" --out "$tmp/o12one" --cache "$cache" "${preset[@]}"
one_entry=$(cd "$cache" && ls oracle-*.bin | head -1)
check "12: a one-light run made an entry" test -n "$one_entry"
mv "$cache/$one_entry" "$tmp/one.bin"
rewrite_entry "$tmp/one.bin" "$cache/$entry" "$key"
run validate "$tmp/s.json" --out "$tmp/o12" --cache "$cache" "${preset[@]}"
check "12: an entry of another light count: validate exits 0, not 4" test "$rc" -eq 0
check "12: ... warning that it holds another frame" grep -q "with 1 lights" <<<"$err"
check "12: ... the verdict a clean cache gives" \
    same_bytes "$tmp/o12/light0.classes.png" "$tmp/prime/light0.classes.png"
check "12: ... the entry replaced by the run's own" \
    test "$(stat -c %s "$cache/$entry")" -gt "$(stat -c %s "$tmp/one.bin")"
cp "$cache/$entry" "$tmp/good.bin"
rewrite_entry "$tmp/good.bin" "$cache/$entry" "$key" nan
run validate "$tmp/s.json" --out "$tmp/o12nan" --cache "$cache" "${preset[@]}"
check "12: NaN truth in an entry with a valid checksum: exit 0" test "$rc" -eq 0
check "12: ... refused with a warning naming NaN" grep -q "NaN" <<<"$err"
check "12: ... the verdict a clean cache gives" \
    same_bytes "$tmp/o12nan/light0.classes.png" "$tmp/prime/light0.classes.png"
fresh_cache

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
