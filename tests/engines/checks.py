"""The engine tests' verdict lines (engines_test.sh, presets_test.sh, vsm_test.sh): one line per
check, "ok" or "FAIL", and finish() exits 1 when any failed."""
import sys

_failed = False


def check(name, cond, detail):
    global _failed
    print(("ok   " if cond else "FAIL ") + name + ": " + detail)
    _failed |= not cond


def finish():
    sys.exit(1 if _failed else 0)
