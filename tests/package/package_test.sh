#!/usr/bin/env bash
# The CMake package end to end: install the build into a temporary prefix, configure and build
# a project outside the tree against it (tests/package/consumer), run its in-process validate on
# data/default, and require the same verdict numbers as `penumbra validate` on the same scenario.
# Usage: package_test.sh BUILD_DIR SOURCE_DIR PENUMBRA_EXE
set -euo pipefail
build=$1 src=$2 exe=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
[[ -f $tmp/prefix/include/penumbra/penumbra.h ]] || fail "no umbrella header installed"
[[ -f $tmp/prefix/lib/cmake/penumbra/penumbraConfig.cmake ]] || fail "no penumbraConfig.cmake installed"
cmake -S "$src/tests/package/consumer" -B "$tmp/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" >/dev/null || fail "the consumer does not configure against the package"
cmake --build "$tmp/consumer" >/dev/null || fail "the consumer does not build against the package"
# The consumer sees only the installed files: nothing of the source tree is on its include path.
grep -q -- "-I$src\b\|isystem $src\b" "$tmp/consumer/build.ninja" && fail "the consumer's include path names the source tree"

scenario=$src/data/default/scenario.json
export PENUMBRA_CACHE_DIR=$tmp/cache
"$tmp/consumer/consumer" "$scenario" >"$tmp/inprocess.json" || fail "the consumer's validate failed"
"$exe" validate "$scenario" --out "$tmp/cli" --no-cache -q || fail "penumbra validate failed"
python3 - "$tmp/inprocess.json" "$tmp/cli/report.json" "$("$exe" --version)" <<'PY'
import json, sys
inproc = json.load(open(sys.argv[1]))
report = json.load(open(sys.argv[2]))
assert sys.argv[3] == "penumbra " + inproc["version"], f"version {inproc['version']} != {sys.argv[3]}"
cli = [{k: v for k, v in l.items() if k not in ("index", "type")} for l in report["lights"]]
assert len(inproc["lights"]) == 3, "data/default has three lights"
for i, (a, b) in enumerate(zip(inproc["lights"], cli)):
    assert a == b, f"light {i}: in-process {a} != CLI {b}"
    assert a["pixels"]["scored"] > 10000, f"light {i}: too few scored pixels"
    assert sum(a["counts"].values()) > 0, f"light {i}: the default technique should leave some wrong pixels"
print("package: in-process verdicts equal the CLI's on", len(cli), "lights")
PY

# A technique family of the consumer's own, registered through the installed interface and
# picked by its "family" key, draws an in-process validate.
"$tmp/consumer/consumer" "$scenario" --own-family >"$tmp/family.json" || fail "the consumer's own family failed"
python3 - "$tmp/family.json" <<'PY'
import json, sys
out = json.load(open(sys.argv[1]))
assert out["family"] == "consumer_all_lit", out
assert out["technique"]["family"] == "consumer_all_lit", out
print("package: a family registered by the consumer drew its validate")
PY

# penumbra::compare through the package: penumbra's own raster frame as an engine's image, the
# same verdict in-process as `penumbra compare` gives.
"$exe" raster "$scenario" --out "$tmp/raster" -q || fail "penumbra raster failed"
[[ -f $tmp/prefix/lib/penumbra/penumbra_oiio.so ]] || fail "no image-reading plugin installed (lib/penumbra/penumbra_oiio.so)"
# The installed libpenumbra.so reads the image through the installed plugin beside it, not the build tree's.
LD_DEBUG=files "$tmp/consumer/consumer" "$scenario" --compare "$tmp/raster/raster.exr" >"$tmp/compare.json" \
  2>"$tmp/ld.log" || fail "the consumer's compare failed"
grep -q "file=$(realpath "$tmp")/prefix/lib/penumbra/penumbra_oiio.so " "$tmp/ld.log" ||
  fail "the consumer did not load the installed plugin: $(grep -o 'file=[^ ]*penumbra_oiio[^ ]*' "$tmp/ld.log" | head -1)"
"$exe" compare "$scenario" --image "$tmp/raster/raster.exr" --out "$tmp/cmp" --no-cache -q || fail "penumbra compare failed"
python3 - "$tmp/compare.json" "$tmp/cmp/report.json" <<'PY'
import json, sys
inproc = json.load(open(sys.argv[1]))
report = json.load(open(sys.argv[2]))
cli = [{k: v for k, v in l.items() if k not in ("index", "type")} for l in report["lights"]]
assert len(inproc["lights"]) == 3
for i, (a, b) in enumerate(zip(inproc["lights"], cli)):
    assert a == b, f"light {i}: in-process compare {a} != CLI {b}"
    assert a["evidence"]["source"] == "oracle_geometry"
print("package: in-process compare equals the CLI's on", len(cli), "lights")
PY
