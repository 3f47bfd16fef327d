#!/usr/bin/env python3
"""Mutation check for penumbra (docs/testing.md, "Mutation testing").

Applies each mutant of tests/mutation/mutants.txt to a scratch copy of the source tree, rebuilds
the test executables that cover it, runs them, and records whether the tests noticed:
  killed     a covering test failed
  survived   every covering test passed: a missing test, or an equivalent mutant
  stillborn  the mutant does not compile (not counted as killed)
  timeout    the tests ran past their limit (counted as killed: the change was noticed)
The user's tree is never touched: the copy lives in <build dir>/mutation/src.
"""

import argparse
import datetime
import hashlib
import os
import random
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
KEYS = ("file", "from", "to", "what", "tests", "build")


class MutantError(Exception):
    pass


def parse_mutants(path):
    """Blocks of `[ID]` followed by `key: value` lines; `#` starts a comment line."""
    mutants, current = [], None
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.rstrip("\n")
            if not text.strip() or text.lstrip().startswith("#"):
                continue
            header = re.fullmatch(r"\[([A-Za-z0-9_.-]+)\]\s*", text)
            if header:
                current = {"id": header.group(1), "line": number}
                mutants.append(current)
                continue
            key, sep, value = text.partition(": ")
            if current is None or not sep or key not in KEYS or key in current:
                raise MutantError(f"{path}:{number}: expected `[ID]` or one of {', '.join(KEYS)} as `key: value`")
            current[key] = value  # verbatim: leading/trailing spaces of the code matter
    ids = set()
    for m in mutants:
        for key in ("file", "from", "to", "what", "tests"):
            if key not in m:
                raise MutantError(f"{path}:{m['line']}: mutant {m['id']} has no `{key}:`")
        if m["id"] in ids:
            raise MutantError(f"{path}:{m['line']}: mutant id {m['id']} is used twice")
        if m["from"] == m["to"]:
            raise MutantError(f"{path}:{m['line']}: mutant {m['id']} changes nothing")
        ids.add(m["id"])
    return mutants


def test_items(m):
    """`exe[:gtest_filter]` runs a test executable; `ctest:REGEX` runs ctest tests (the CLI scripts)."""
    return m["tests"].split()


def targets_of(m):
    targets = set(m.get("build", "").split())
    for item in test_items(m):
        if item.startswith("ctest:"):
            targets.add("penumbra")
        else:
            targets.add(item.split(":", 1)[0])
    return sorted(targets)


def tracked_files():
    out = subprocess.run(["git", "-C", ROOT, "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                         check=True, capture_output=True).stdout
    return [p for p in out.decode().split("\0") if p and os.path.isfile(os.path.join(ROOT, p))]


def sync_tree(scratch):
    """Copies the tree (committed and uncommitted, not ignored) into scratch, writing only files whose
    content differs, so that their fresh mtime makes ninja rebuild them; a file left mutated by an
    interrupted run differs from the tree and is rewritten too."""
    changed = 0
    for rel in tracked_files():
        src, dst = os.path.join(ROOT, rel), os.path.join(scratch, rel)
        with open(src, "rb") as f:
            data = f.read()
        if os.path.exists(dst):
            with open(dst, "rb") as f:
                if f.read() == data:
                    continue
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        with open(dst, "wb") as f:
            f.write(data)
        shutil.copymode(src, dst)
        changed += 1
    return changed


def nice(cmd):
    return ["nice", "-n", "10"] + cmd


def configure(scratch, build):
    if os.path.exists(os.path.join(build, "build.ninja")):
        return
    cmd = ["cmake", "-S", scratch, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
           "-DPENUMBRA_WERROR=OFF", "-DPENUMBRA_BUILD_BENCH=OFF"]
    if shutil.which("ccache"):
        cmd += ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DCMAKE_C_COMPILER_LAUNCHER=ccache"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def build_targets(build, targets, jobs, log):
    r = subprocess.run(nice(["ninja", "-C", build, f"-j{jobs}"] + targets), stdout=log, stderr=subprocess.STDOUT)
    return r.returncode == 0


def run_tests(build, m, limit, log):
    """Returns 'pass', 'fail' or 'timeout'; the first failing item decides, which keeps killed
    mutants cheap."""
    deadline = time.monotonic() + limit
    for item in test_items(m):
        left = deadline - time.monotonic()
        if left <= 0:
            return "timeout"
        if item.startswith("ctest:"):
            # A regex that matches nothing must not pass as "every test passed".
            cmd = ["ctest", "--test-dir", build, "--output-on-failure", "--no-tests=error", "-R", item[len("ctest:"):]]
        else:
            exe, _, flt = item.partition(":")
            cmd = [os.path.join(build, "tests", exe), "--gtest_brief=1"]
            if flt:
                cmd.append(f"--gtest_filter={flt}")
        log.write(f"$ {' '.join(cmd)}\n".encode())
        log.flush()
        try:
            r = subprocess.run(nice(cmd), stdout=log, stderr=subprocess.STDOUT, timeout=left,
                               start_new_session=True)
        except subprocess.TimeoutExpired:
            return "timeout"
        if r.returncode != 0:
            return "fail"
    return "pass"


def apply(scratch, m):
    path = os.path.join(scratch, m["file"])
    if not os.path.isfile(path):
        raise MutantError(f"mutant {m['id']}: {m['file']} does not exist")
    with open(path, encoding="utf-8") as f:
        original = f.read()
    count = original.count(m["from"])
    if count != 1:
        raise MutantError(f"mutant {m['id']}: the original text {m['from']!r} occurs {count} times in "
                          f"{m['file']}, not once (a stale mutant must not count as killed)")
    with open(path, "w", encoding="utf-8") as f:
        f.write(original.replace(m["from"], m["to"]))
    return path, original


def restore(path, original):
    # A fresh mtime (not the old one): the object built from the mutant must be rebuilt.
    with open(path, "w", encoding="utf-8") as f:
        f.write(original)


def module_of(m):
    return m["file"].split("/")[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ids", nargs="*", metavar="ID", help="run only these mutants")
    ap.add_argument("--sample", type=int, metavar="N", help="run N mutants picked by --seed")
    ap.add_argument("--seed", default="0", metavar="S", help="seed for --sample (e.g. the date in CI)")
    ap.add_argument("--list", default=os.path.join(HERE, "mutants.txt"), help="the mutant list")
    ap.add_argument("--build-dir", default=os.environ.get("PENUMBRA_BUILD_DIR", os.path.join(ROOT, "build")),
                    help="the scratch copy goes in BUILD_DIR/mutation (default: build)")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=int, default=600, help="seconds for one mutant's tests (default 600)")
    ap.add_argument("--check", action="store_true", help="only check that every mutant applies exactly once")
    ap.add_argument("--markdown", help="write the table here (default BUILD_DIR/mutation/results.md)")
    args = ap.parse_args()

    try:
        mutants = parse_mutants(args.list)
    except MutantError as e:
        print(f"mutation: {e}", file=sys.stderr)
        return 2
    if args.ids:
        known = {m["id"]: m for m in mutants}
        unknown = [i for i in args.ids if i not in known]
        if unknown:
            print(f"mutation: no mutant named {', '.join(unknown)} in {args.list}", file=sys.stderr)
            return 2
        mutants = [known[i] for i in args.ids]
    if args.sample is not None:
        # Deterministic for a seed, independent of Python's hash randomisation.
        rng = random.Random(int(hashlib.sha256(args.seed.encode()).hexdigest(), 16))
        mutants = sorted(rng.sample(mutants, min(args.sample, len(mutants))), key=lambda m: m["line"])

    # Every mutant must apply to the tree as it is, before any time goes into building.
    stale = []
    for m in mutants:
        try:
            with open(os.path.join(ROOT, m["file"]), encoding="utf-8") as f:
                count = f.read().count(m["from"])
        except FileNotFoundError:
            count = 0
        if count != 1:
            stale.append(f"  {m['id']}: {m['file']}: {m['from']!r} occurs {count} times")
    if stale:
        print("mutation: stale mutants (the original text must occur exactly once):\n" + "\n".join(stale),
              file=sys.stderr)
        return 2
    if args.check:
        print(f"mutation: {len(mutants)} mutants apply")
        return 0

    work = os.path.join(os.path.abspath(args.build_dir), "mutation")
    # Sources in work/src and the build in work/src/build: the same relative layout as a build/
    # in the checkout, so ccache (base_dir) reuses objects compiled there.
    scratch = os.path.join(work, "src")
    build = os.path.join(scratch, "build")
    logs = os.path.join(work, "logs")
    os.makedirs(logs, exist_ok=True)
    os.makedirs(scratch, exist_ok=True)
    changed = sync_tree(scratch)
    print(f"mutation: scratch copy {scratch} ({changed} files updated)", flush=True)
    configure(scratch, build)

    targets = sorted({t for m in mutants for t in targets_of(m)})
    print(f"mutation: building {' '.join(targets)}", flush=True)
    with open(os.path.join(logs, "baseline.log"), "wb") as log:
        if not build_targets(build, targets, args.jobs, log):
            print(f"mutation: the unmutated tree does not build, see {log.name}", file=sys.stderr)
            return 3
        # The covering tests must pass on the unmutated tree, or a failure would prove nothing.
        baseline = {}
        for item in sorted({i for m in mutants for i in test_items(m)}):
            start = time.monotonic()
            outcome = run_tests(build, {"tests": item}, args.timeout, log)
            baseline[item] = time.monotonic() - start
            if outcome != "pass":
                print(f"mutation: the unmutated tree fails `{item}` ({outcome}), see {log.name}", file=sys.stderr)
                return 3
            print(f"mutation: baseline `{item}` passes in {baseline[item]:.0f} s", flush=True)

    results = []
    for n, m in enumerate(mutants, 1):
        start = time.monotonic()
        path, original = apply(scratch, m)
        with open(os.path.join(logs, f"{m['id']}.log"), "wb") as log:
            try:
                log.write(f"{m['id']}: {m['file']}: {m['from']!r} -> {m['to']!r}\n".encode())
                if not build_targets(build, targets_of(m), args.jobs, log):
                    result = "stillborn"
                else:
                    limit = min(args.timeout, max(60, 5 * sum(baseline[i] for i in test_items(m))))
                    outcome = run_tests(build, m, limit, log)
                    result = {"fail": "killed", "pass": "survived", "timeout": "timeout"}[outcome]
            finally:
                restore(path, original)
        seconds = time.monotonic() - start
        results.append((m, result, seconds))
        print(f"mutation: [{n}/{len(mutants)}] {m['id']:<10} {result:<9} {seconds:5.0f} s  {m['what']}", flush=True)

    killed = sum(r in ("killed", "timeout") for _, r, _ in results)
    stillborn = sum(r == "stillborn" for _, r, _ in results)
    viable = len(results) - stillborn
    rate = 100.0 * killed / viable if viable else 0.0
    lines = ["| id | module | description | result |", "|---|---|---|---|"]
    for m, r, _ in results:
        what = m["what"].replace("|", "\\|")
        lines.append(f"| {m['id']} | {module_of(m)} | {what} | {r} |")
    summary = (f"{killed} of {viable} mutants killed ({rate:.0f}%), {len(results) - stillborn - killed} survived, "
               f"{stillborn} stillborn; {sum(s for _, _, s in results) / max(1, len(results)):.0f} s per mutant")
    table = "\n".join(lines) + "\n\n" + summary + "\n"
    out = args.markdown or os.path.join(work, "results.md")
    with open(out, "w", encoding="utf-8") as f:
        f.write(f"Mutation run {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC\n\n" + table)
    print("\n" + table + f"\nmutation: table written to {out}")
    return 0 if all(r != "survived" for _, r, _ in results) else 1


if __name__ == "__main__":
    sys.exit(main())
