#!/usr/bin/env python3
"""How far apart the times of two identical batches are: the noise any "A is faster than B"
drawn from runs of different batches (or nights) has to beat.

    cargo build --release
    python3 scripts/bench_noise.py configs/noise.toml --repeat 5

Runs the config twice, one batch after the other, each with `--repeat N --jobs J`, and
reports per run the ratio between the two batches (larger over smaller, so 1.00 is perfect)
of `time_norm` (the median over repeats divided by the batch's calibration time) and, for
comparison, of the raw `time_s`. The issue's target: median `time_norm` ratio <= 1.10 with
`--repeat 5` (single-shot `time_s` on an idle machine: 1.40). Standard library only; not
part of CI (its pure part is tested in scripts/tests/test_bench_noise.py).
"""

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile


def read_summary(path):
    """The timed runs of a summary.csv: {(dataset, energy, solver): row}."""
    with open(path, newline="") as f:
        return {
            (r["dataset"], r["energy"], r["solver"]): r
            for r in csv.DictReader(f)
            if r.get("status") in ("ok", "not_converged") and r.get("time_s")
        }


def ratio(a, b):
    """Larger over smaller: how far apart two positive times are, whichever is slower."""
    if a <= 0 or b <= 0:
        return None
    return max(a, b) / min(a, b)


def ratios(first, second, column):
    """Per run present in both batches with `column`, the ratio between them."""
    out = {}
    for key in sorted(first.keys() & second.keys()):
        a, b = first[key].get(column), second[key].get(column)
        if a and b:
            r = ratio(float(a), float(b))
            if r is not None:
                out[key] = r
    return out


def calibration(run_dir):
    with open(os.path.join(run_dir, "meta.json")) as f:
        meta = json.load(f)
    return meta.get("calibration_median_s"), meta.get("calibration_spread")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--mapbench", default=os.path.join("target", "release", "mapbench"))
    args = ap.parse_args()
    if not os.path.exists(args.mapbench):
        sys.exit(f"{args.mapbench}: not found (cargo build --release, or pass --mapbench)")
    with tempfile.TemporaryDirectory() as tmp:
        dirs = []
        for batch in ("a", "b"):
            out = os.path.join(tmp, batch)
            cmd = [args.mapbench, "run", args.config, "--out", out, "--repeat", str(args.repeat), "--jobs", str(args.jobs)]
            p = subprocess.run(cmd, capture_output=True, text=True)
            if p.returncode not in (0, 1):
                sys.exit(f"batch {batch} exited with {p.returncode}:\n{p.stdout}{p.stderr}")
            dirs.append(out)
            median_s, spread = calibration(out)
            print(f"batch {batch}: calibration median {median_s:.4f} s, spread {100 * spread:.1f}%", flush=True)
        first, second = (read_summary(os.path.join(d, "summary.csv")) for d in dirs)
    norm, raw = ratios(first, second, "time_norm"), ratios(first, second, "time_s")
    print(f"{'run':<48} {'time_norm':>10} {'time_s':>10}")
    for key in sorted(raw):
        n = f"{norm[key]:.3f}" if key in norm else "-"
        print(f"{'__'.join(key):<48} {n:>10} {raw[key]:>10.3f}")
    if not raw:
        sys.exit("no run was timed in both batches")
    summary = {
        "repeat": args.repeat,
        "jobs": args.jobs,
        "runs": len(raw),
        "median_ratio_time_norm": statistics.median(norm.values()) if norm else None,
        "median_ratio_time_s": statistics.median(raw.values()),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
