#!/usr/bin/env python3
"""What a newcomer and CI wait for, measured on a fresh clone (issue: fast by default).

    python3 scripts/fresh_clone.py              # build, then the default nightly (configs/param.toml)
    python3 scripts/fresh_clone.py --ci         # bash .ci/run in the clone, each step's seconds
    python3 scripts/fresh_clone.py --times 3    # the nightly path three times, one after the other

The clone is of the committed HEAD (uncommitted changes are not in it), beside this repository
so that ../shared is found as CI finds it, with its own target/ (the cargo registry is reused:
downloads are not timed). The nightly path is `cargo build --release --locked`, then the built
binary's `run configs/param.toml` (what `cargo run --release -- run configs/param.toml` does,
timed apart). Prints Markdown rows for the Results pages (docs/src/results/nightly.md,
docs/src/design/testing.md): the numbers come from here, never from a timed test. The clone is
removed at the end unless --keep. Standard library only.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# A step header of .ci/run: `== what [HH:MM:SS, +Ns]`.
STEP = re.compile(r"^== (.*) \[\d\d:\d\d:\d\d, \+(\d+)s\]\s*$")


def step_times(log, total=None):
    """(step, seconds) for each step header of a .ci/run log, each lasting until the next header
    (the last until `total` seconds, when given; a last header `done` takes no time)."""
    heads = [(m.group(1), int(m.group(2))) for m in map(STEP.match, log.splitlines()) if m]
    out = []
    for i, (what, at) in enumerate(heads):
        end = heads[i + 1][1] if i + 1 < len(heads) else total
        if end is not None and what != "done":
            out.append((what, end - at))
    return out


def minutes(seconds):
    """`6 min 26 s` (seconds rounded)."""
    s = int(round(seconds))
    return f"{s // 60} min {s % 60} s" if s >= 60 else f"{s} s"


def run(argv, cwd, log_path, env=None):
    """Run argv in cwd with its output in log_path; (seconds, exit code)."""
    t0 = time.monotonic()
    with open(log_path, "w") as log:
        code = subprocess.call(argv, cwd=cwd, stdout=log, stderr=subprocess.STDOUT, env=env)
    return time.monotonic() - t0, code


def clone(dest):
    if os.path.exists(dest):
        shutil.rmtree(dest)
    subprocess.check_call(["git", "clone", "--quiet", "--no-hardlinks", ROOT, dest])
    return subprocess.check_output(["git", "rev-parse", "--short", "HEAD"], cwd=dest, text=True).strip()


def nightly(dest, logs):
    """Build and default nightly in the clone: (revision, build s, batch s) or None on failure."""
    revision = clone(dest)
    env = dict(os.environ)
    env.pop("CARGO_TARGET_DIR", None)
    env.pop("MAPBENCH_MESHES", None)  # the default nightly runs the generated corpus only
    build, code = run(["cargo", "build", "--release", "--locked"], dest, os.path.join(logs, "build.log"), env)
    if code != 0:
        print(f"the build failed (exit {code}): {logs}/build.log", file=sys.stderr)
        return None
    batch, code = run(
        [os.path.join(dest, "target", "release", "mapbench"), "run", "configs/param.toml", "--no-history"],
        dest, os.path.join(logs, "batch.log"), env,
    )
    if code not in (0, 1):  # 1: some runs failed, the report is written
        print(f"the batch failed (exit {code}): {logs}/batch.log", file=sys.stderr)
        return None
    return revision, build, batch


def ci(dest, logs):
    """.ci/run in the clone: (revision, total s, exit code, [(step, s)])."""
    revision = clone(dest)
    env = dict(os.environ)
    env.pop("CARGO_TARGET_DIR", None)
    log_path = os.path.join(logs, "ci.log")
    total, code = run(["bash", ".ci/run"], dest, log_path, env)
    with open(log_path) as f:
        steps = step_times(f.read(), total)
    return revision, total, code, steps


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ci", action="store_true", help="time .ci/run and its steps instead of the nightly path")
    ap.add_argument("--times", type=int, default=1, help="measure this many times, one after the other")
    ap.add_argument("--dest", default=os.path.join(os.path.dirname(ROOT), "mapbench-fresh-clone"))
    ap.add_argument("--keep", action="store_true", help="keep the clone (and its target/)")
    a = ap.parse_args()
    logs = os.path.join(os.path.dirname(a.dest), os.path.basename(a.dest) + "-logs")
    os.makedirs(logs, exist_ok=True)
    failed = False
    date = time.strftime("%Y-%m-%d", time.gmtime())
    for i in range(a.times):
        if a.ci:
            revision, total, code, steps = ci(a.dest, logs)
            print(f"\n.ci/run at {revision}, {date}: {minutes(total)}, exit {code} (log: {logs}/ci.log)\n")
            print("| step | time |\n| --- | ---: |")
            for what, s in sorted(steps, key=lambda x: -x[1]):
                print(f"| {what[:90]} | {minutes(s)} |")
            failed |= code != 0
        else:
            got = nightly(a.dest, logs)
            if got is None:
                failed = True
                continue
            revision, build, batch = got
            if i == 0:
                print("| revision | date | build | batch | total |\n| --- | --- | --- | --- | --- |")
            print(f"| {revision} | {date} | {minutes(build)} | {minutes(batch)} | {minutes(build + batch)} |")
        if not a.keep:
            shutil.rmtree(a.dest, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
