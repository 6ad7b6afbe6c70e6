#!/usr/bin/env python3
"""Wall time of a whole batch with `--jobs 1` against `--jobs N`, interleaved round by round.

    cargo build --release
    python3 scripts/bench_jobs.py configs/jobs.toml --rounds 5

Each round runs the config once with every job count into a fresh temporary folder (runs,
summary, report: the whole `mapbench run`), so machine noise hits every setting alike.
Prints the median wall time per job count and the speed-up over `--jobs 1` (issue target:
>= 1.8x with 2 jobs on a batch of small meshes). Standard library only; not part of CI.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="job counts to compare (first is the reference)")
    ap.add_argument("--mapbench", default=os.path.join("target", "release", "mapbench"))
    args = ap.parse_args()
    if not os.path.exists(args.mapbench):
        sys.exit(f"{args.mapbench}: not found (cargo build --release, or pass --mapbench)")
    times = {j: [] for j in args.jobs}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for j in args.jobs:
                out = os.path.join(tmp, f"jobs{j}")
                shutil.rmtree(out, ignore_errors=True)
                t0 = time.perf_counter()
                p = subprocess.run(
                    [args.mapbench, "run", args.config, "--out", out, "--jobs", str(j)],
                    capture_output=True, text=True,
                )
                dt = time.perf_counter() - t0
                if p.returncode != 0:
                    sys.exit(f"--jobs {j} exited with {p.returncode}:\n{p.stdout}{p.stderr}")
                times[j].append(dt)
            print(f"round {r + 1}/{args.rounds}: " + ", ".join(f"jobs {j} {times[j][-1]:.3f} s" for j in args.jobs),
                  flush=True)
    ref = statistics.median(times[args.jobs[0]])
    for j in args.jobs:
        m = statistics.median(times[j])
        print(f"--jobs {j}: median {m:.3f} s, speed-up {ref / m:.2f}x")


if __name__ == "__main__":
    main()
