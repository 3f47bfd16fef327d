#!/usr/bin/env bash
# Makes a self-contained folder to run the raster tests and benches on a GPU machine that has a
# Vulkan driver but none of penumbra's development packages (docs/testing.md, "On a GPU
# machine"): the test and bench binaries of an existing Release build, the shared libraries they
# need beyond what the machine has (Embree, TBB, fmt, ...), data/default, and run.sh.
#   scripts/gpu-bundle.sh OUTDIR [--build DIR] [--with-validation-layer]
# --with-validation-layer copies the Khronos validation layer in too (21 MiB: the folder then
# exceeds 64 MiB); without it raster_tests need the machine's vulkan-validationlayers package.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=""
build="$root/build"
with_layer=0
while (($#)); do
    case $1 in
        --build) build=$(cd "$2" && pwd); shift 2 ;;
        --with-validation-layer) with_layer=1; shift ;;
        -h | --help) sed -n '2,8p' "$0"; exit 0 ;;
        -*) echo "gpu-bundle: unknown option $1" >&2; exit 2 ;;
        *) out=$1; shift ;;
    esac
done
if [[ -z $out ]]; then
    echo "usage: scripts/gpu-bundle.sh OUTDIR [--build DIR] [--with-validation-layer]" >&2
    exit 2
fi

binaries=(tests/raster_tests tests/verdict_tests tests/tune_tests bench/raster_bench bench/raster_session_bench
    bench/receiver_plane_probe bench/class_counts bench/tune_bench bench/sweep_bench)
for b in "${binaries[@]}"; do
    if [[ ! -x $build/$b ]]; then
        echo "gpu-bundle: $build/$b is missing: build first (scripts/build.sh)" >&2
        exit 1
    fi
    # The bundle must not carry OpenImageIO's ~260 libraries: only image_io's reading plugin
    # (penumbra_oiio.so) links it, and these binaries never load it.
    if ldd "$build/$b" | grep -qi openimageio; then
        echo "gpu-bundle: $b links OpenImageIO; it should not (image_io/oiio_plugin.h)" >&2
        exit 1
    fi
done

rm -rf "$out"
mkdir -p "$out/bin" "$out/lib" "$out/data"
for b in "${binaries[@]}"; do cp "$build/$b" "$out/bin/"; done
cp -r "$root/data/default" "$root/data/soft" "$out/data/"

# Every shared library the binaries load except those any Ubuntu 24.04 / Debian 12 machine with
# a Vulkan driver has: the C and C++ runtimes, and the Vulkan loader (which must match the
# machine's driver setup, so it comes from the machine's packages).
system_lib='^(linux-vdso|ld-linux|libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt|libvulkan)\.so'
declare -A copied=()
for b in "${binaries[@]}"; do
    while read -r name _ path _; do
        [[ $path == /* ]] || continue
        [[ $name =~ $system_lib ]] && continue
        [[ -n ${copied[$name]:-} ]] && continue
        cp -L "$path" "$out/lib/$name"
        copied[$name]=1
    done < <(ldd "$build/$b")
done

if ((with_layer)); then
    layer_json=$(ls /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json)
    mkdir -p "$out/layers"
    layer_so=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' "$layer_json")
    [[ $layer_so == /* ]] || layer_so=$(ldconfig -p | awk -v n="$layer_so" '$1 == n {print $NF; exit}')
    cp -L "$layer_so" "$out/layers/"
    sed "s|\"library_path\": *\"[^\"]*\"|\"library_path\": \"./$(basename "$layer_so")\"|" "$layer_json" \
        >"$out/layers/VkLayer_khronos_validation.json"
fi

cat >"$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# Runs penumbra's raster tests and benches from this folder (made by scripts/gpu-bundle.sh).
#   bash run.sh [DEVICE]    DEVICE: a Vulkan device index or name part (default: $PENUMBRA_VK_DEVICE,
#                           else lavapipe); logs go to $PENUMBRA_BUNDLE_LOGS (default: ./logs).
set -u
here=$(cd "$(dirname "$0")" && pwd)
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PENUMBRA_DATA_DIR="$here/data"
if [[ -d $here/layers ]]; then
    export VK_ADD_LAYER_PATH="$here/layers${VK_ADD_LAYER_PATH:+:$VK_ADD_LAYER_PATH}"
fi
if (($#)); then export PENUMBRA_VK_DEVICE=$1; fi
device_args=()
if [[ -n ${PENUMBRA_VK_DEVICE:-} ]]; then device_args=(--device "$PENUMBRA_VK_DEVICE"); fi
logs=${PENUMBRA_BUNDLE_LOGS:-$here/logs}
mkdir -p "$logs"

layer_found=0
for d in "$here/layers" ${VK_LAYER_PATH:+${VK_LAYER_PATH//:/ }} /usr/share/vulkan/explicit_layer.d /etc/vulkan/explicit_layer.d \
    /usr/local/share/vulkan/explicit_layer.d; do
    [[ -f $d/VkLayer_khronos_validation.json ]] && layer_found=1
done
if ((!layer_found)); then
    echo "note: the Khronos validation layer is not installed; raster_tests run under it and will fail" \
        "(apt-get install vulkan-validationlayers, or make the bundle with --with-validation-layer)" >&2
fi

summary=()
failed=0
step() {
    local name=$1
    shift
    local t0=$SECONDS
    "$@" >"$logs/$name.log" 2>&1
    local rc=$?
    local line
    if ((rc == 0)); then line="PASS"; else line="FAIL (exit $rc)"; failed=1; fi
    summary+=("$(printf '%-22s %-16s %4ds  %s' "$name" "$line" $((SECONDS - t0)) "$logs/$name.log")")
    echo "${summary[-1]}"
}
echo "penumbra GPU bundle: device ${PENUMBRA_VK_DEVICE:-(default: lavapipe when installed, else device 0)}"
step raster_tests "$here/bin/raster_tests"
step verdict_tests "$here/bin/verdict_tests"
step tune_tests "$here/bin/tune_tests"
step raster_bench "$here/bin/raster_bench" "${device_args[@]}"
step raster_session_bench "$here/bin/raster_session_bench" "${device_args[@]}"
step receiver_plane_probe "$here/bin/receiver_plane_probe" "${device_args[@]}"
step class_counts "$here/bin/class_counts" "${device_args[@]}" "$here/data/default/scenario.json" \
    "$here/data/soft/scenario.json"
step tune_bench "$here/bin/tune_bench" "${device_args[@]}" --repeat 7 --grid 16 --budget 25
sweep=(--vary resolution=1024,2048,4096,8192)
step sweep_default "$here/bin/sweep_bench" "${device_args[@]}" "${sweep[@]}" --vary filter.type=none,hw2x2,poisson
step sweep_default_pcf "$here/bin/sweep_bench" "${device_args[@]}" --set filter.type=pcf "${sweep[@]}" \
    --vary filter.size=3,5
step sweep_soft_pcss "$here/bin/sweep_bench" "${device_args[@]}" --scenario "$here/data/soft/scenario.json" \
    "${sweep[@]}" --vary filter.type=pcf,pcss
step sweep_terrain_2m "$here/bin/sweep_bench" "${device_args[@]}" --terrain-grid 1024 "${sweep[@]}" \
    --vary filter.type=none,hw2x2,pcf,poisson
step tune_bench_all_lights "$here/bin/tune_bench" "${device_args[@]}" --repeat 7 --all-lights --grid 16 --budget 25

echo
echo "summary:"
printf '  %s\n' "${summary[@]}"
for t in raster_tests verdict_tests tune_tests; do
    grep -hE '^\[  (PASSED|FAILED)  \]' "$logs/$t.log" | sed "s/^/  $t: /"
done
exit $failed
RUN
chmod +x "$out/run.sh"

size=$(du -sb "$out" | cut -f1)
echo "gpu-bundle: $out, $((size / 1048576)) MiB ($size bytes): bin/ $(ls "$out/bin" | tr '\n' ' ')"
echo "gpu-bundle: lib/ $(ls "$out/lib" | tr '\n' ' ')"
if ((size >= 64 * 1048576)); then echo "gpu-bundle: warning: over 64 MiB" >&2; fi
