#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the Release build (warnings as errors) and an
# AddressSanitizer + UndefinedBehaviorSanitizer build of the unit tests.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/build.sh"
(cd "$root/build" && ctest -j2 --output-on-failure)

cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DPENUMBRA_WERROR=ON \
  -DPENUMBRA_SANITIZE=ON -DPENUMBRA_BUILD_BENCH=OFF >/dev/null
ninja -C "$root/build-asan" common_tests oracle_tests raster_tests metrics_tests report_tests stress_tests
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd "$root/build-asan" && ctest -j2 --output-on-failure -L unit)

# Fuzz smoke (docs/testing.md, "Fuzzing"): the libFuzzer targets, built with clang in their own
# folder, each run briefly on its seeds; a crash, timeout or leak fails the suite.
if command -v clang++ >/dev/null; then
    cmake -S "$root" -B "$root/build-fuzz" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
        "-DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer" \
        -DPENUMBRA_FUZZ=ON -DPENUMBRA_BUILD_BENCH=OFF >/dev/null
    ninja -C "$root/build-fuzz" fuzz_gltf fuzz_glb fuzz_scenario fuzz_technique fuzz_gate fuzz_sweep_shard fuzz_sweep_vary fuzz_diff \
        fuzz_cache_entry fuzz_units
    for target in gltf glb scenario technique gate sweep_shard sweep_vary diff cache_entry units; do
        if ! bash "$root/tests/fuzz/run.sh" "$target" "${PENUMBRA_FUZZ_SECONDS:-30}" >"$root/build-fuzz/smoke-$target.log" 2>&1; then
            tail -n 60 "$root/build-fuzz/smoke-$target.log"
            echo "fuzz smoke: fuzz_$target failed (log: build-fuzz/smoke-$target.log)" >&2
            exit 1
        fi
        grep -E '^stat::number_of_executed_units' "$root/build-fuzz/smoke-$target.log" | sed "s/^/fuzz_$target: /"
    done
else
    echo "fuzz smoke skipped: clang++ not installed (scripts/install-deps.sh installs it)"
fi
