#!/usr/bin/env bash
# Makes a self-contained folder to time the oracle on a many-core machine that has none of
# penumbra's development packages (issue #39; docs/oracle.md, "The oracle on many cores"): the
# penumbra command and oracle_bench of an existing Release build, optionally a second penumbra
# to compare with (--baseline), the shared libraries they need beyond the C and C++ runtimes
# (gzip-compressed: Embree alone is 42 MB), and run.sh, which unpacks them and runs
# `oracle_bench --threads-sweep` with its arguments (the scenes are generated there).
#   scripts/oracle-bundle.sh OUTDIR [--build DIR] [--baseline PENUMBRA]
#   then, on the other machine: bash OUTDIR/run.sh --scenes field32,field64 [--repeat 3] ...
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=""
build="$root/build"
baseline=""
while (($#)); do
    case $1 in
        --build) build=$(cd "$2" && pwd); shift 2 ;;
        --baseline) baseline=$(realpath "$2"); shift 2 ;;
        -h | --help) sed -n '2,9p' "$0"; exit 0 ;;
        -*) echo "oracle-bundle: unknown option $1" >&2; exit 2 ;;
        *) out=$1; shift ;;
    esac
done
if [[ -z $out ]]; then
    echo "usage: scripts/oracle-bundle.sh OUTDIR [--build DIR] [--baseline PENUMBRA]" >&2
    exit 2
fi
binaries=("$build/app/penumbra" "$build/bench/oracle_bench")
[[ -n $baseline ]] && binaries+=("$baseline")
for b in "${binaries[@]}"; do
    [[ -x $b ]] || { echo "oracle-bundle: $b is missing: build first" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out/bin" "$out/lib.tmp"
cp "$build/app/penumbra" "$build/bench/oracle_bench" "$out/bin/"
[[ -n $baseline ]] && cp "$baseline" "$out/bin/penumbra-baseline"
system_lib='^(linux-vdso|ld-linux|libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt)\.so'
declare -A copied=()
for b in "${binaries[@]}"; do
    while read -r name _ path _; do
        [[ $path == /* ]] || continue
        [[ $name =~ $system_lib ]] && continue
        [[ -n ${copied[$name]:-} ]] && continue
        cp -L "$path" "$out/lib.tmp/$name"
        copied[$name]=1
    done < <(ldd "$b")
done
tar -C "$out/lib.tmp" -czf "$out/lib.tar.gz" .
rm -rf "$out/lib.tmp"
cat >"$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# Unpacks the libraries and runs oracle_bench --threads-sweep (against bin/penumbra-baseline
# where the bundle has one); arguments go to oracle_bench.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
lib=$(mktemp -d)
tar -C "$lib" -xzf "$here/lib.tar.gz"
export LD_LIBRARY_PATH="$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
args=(--threads-sweep --penumbra "$here/bin/penumbra")
[[ -x $here/bin/penumbra-baseline ]] && args+=(--baseline "$here/bin/penumbra-baseline")
exec "$here/bin/oracle_bench" "${args[@]}" "$@"
RUN
chmod +x "$out/run.sh"
du -sh "$out"
