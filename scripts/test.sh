#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the Release build (warnings as errors) and an
# AddressSanitizer + UndefinedBehaviorSanitizer build of the unit tests.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/build.sh"
(cd "$root/build" && ctest -j2 --output-on-failure)

cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DPENUMBRA_WERROR=ON \
  -DPENUMBRA_SANITIZE=ON -DPENUMBRA_BUILD_BENCH=OFF >/dev/null
ninja -C "$root/build-asan" common_tests oracle_tests raster_tests metrics_tests report_tests
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd "$root/build-asan" && ctest -j2 --output-on-failure -L unit)
