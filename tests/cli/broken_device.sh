#!/usr/bin/env bash
# A Vulkan setup that cannot be used must fail the GPU suites, never skip them: a broken driver
# in CI would otherwise pass. The loader is pointed at an ICD manifest that does not exist, and
# each suite that opens a device must exit non-zero with FAILED tests, none SKIPPED.
# Usage: broken_device.sh RASTER_TESTS VERDICT_TESTS COMPARE_TESTS
set -uo pipefail
failed=0
passed=0
for suite in "$@"; do
    name=$(basename "$suite")
    out=$(VK_ICD_FILENAMES=/nonexistent/penumbra-bogus-icd.json VK_DRIVER_FILES=/nonexistent/penumbra-bogus-icd.json \
        PENUMBRA_VK_VALIDATION=0 timeout 300 "$suite" --gtest_brief=0 2>&1)
    rc=$?
    if [[ $rc -eq 0 ]]; then
        echo "FAIL: $name exits 0 without a usable Vulkan device"
        failed=$((failed + 1))
    elif ! grep -q '\[  FAILED  \]' <<<"$out"; then
        echo "FAIL: $name exits $rc without naming failed tests"
        failed=$((failed + 1))
    elif grep -q '\[  SKIPPED \]' <<<"$out"; then
        echo "FAIL: $name skips tests without a usable Vulkan device"
        failed=$((failed + 1))
    else
        passed=$((passed + 1))
    fi
done
echo "$passed passed, $failed failed"
test "$failed" -eq 0
