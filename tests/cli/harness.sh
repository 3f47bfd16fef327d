# Sourced by the CLI test scripts (tests/cli/*.sh): their two arguments, a temporary folder
# removed at exit, run() (penumbra with stdout and stderr kept; sets rc and err), check(), which
# counts and names each failure, fails() and html_check(). A script may define fail_detail() to
# add context to a failure line (e.g. the exit code and stderr). End a script with `finish`.
set -uo pipefail
bin=$1
src=$2
tmp=$(mktemp -d)
trap 'chmod -R u+w "$tmp" 2>/dev/null; rm -rf "$tmp"' EXIT
passed=0
failed=0
check() {  # check NAME CONDITION...
    local name=$1
    shift
    if "$@"; then
        passed=$((passed + 1))
    else
        failed=$((failed + 1))
        echo "FAIL: $name$(declare -F fail_detail >/dev/null && echo " $(fail_detail)")"
    fi
}
run() {  # run ARGS... -> runs penumbra; sets rc, err
    "$bin" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    err=$(cat "$tmp/stderr")
}
fails() { ! "$@"; }
# A tool the project's scripts install (scripts/install-deps.sh) must be there: a missing one is
# a failure, never a silent skip. require_tool NAME PATH_OR_COMMAND
require_tool() {
    if command -v "$2" >/dev/null 2>&1 || [[ -e $2 ]]; then return 0; fi
    failed=$((failed + 1))
    echo "FAIL: $1 is missing ($2): scripts/install-deps.sh installs it"
    return 1
}
# The page opens in headless Chromium at 1280 px with every image decoded, no console message
# and nothing wider than the window (pages carry report::image_check_script()).
html_check() {  # html_check FILE -> 0 when clean
    timeout 120 chromium --headless --no-sandbox --disable-gpu --enable-logging=stderr --v=0 --window-size=1280,900 \
        --dump-dom "file://$1" >"$tmp/dom.html" 2>"$tmp/browser.log" || return 1
    if ! grep -q 'data-layout="ok"' "$tmp/dom.html"; then
        echo "  layout: $(grep -o 'data-layout="[^"]*"' "$tmp/dom.html")"
        return 1
    fi
    grep -q 'data-images="ok"' "$tmp/dom.html" && ! grep -q ':CONSOLE' "$tmp/browser.log"
}
finish() {
    echo "$passed passed, $failed failed"
    test "$failed" -eq 0
}
