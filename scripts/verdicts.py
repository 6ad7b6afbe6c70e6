#!/usr/bin/env python3
"""The harness's verdicts of run folders side by side, per solver, as Markdown for a Results page.

    python3 scripts/verdicts.py BEFORE [AFTER] [--energy sd] [--ends]

Per solver, from each folder's summary.csv: the runs that ran, solved (the verdict, at each
energy's tightest target), reached each target of the folder (`iters_to_<tau>` filled: a
target an energy is not judged at is never reached), and the other verdicts. With two folders,
each count is `before → after` on the runs both have. `--ends` prints instead how the runs
ended (`stop_reason`) with their count and summed `time_s`, per folder. Standard library only.
"""

import argparse
import collections
import csv
import os
import sys


def rows(folder):
    """The runs of a folder that ran (not skipped, not failed), by (dataset, energy, solver)."""
    with open(os.path.join(folder, "summary.csv"), newline="") as f:
        out = {}
        for r in csv.DictReader(f):
            if r["status"] in ("skipped", "failed"):
                continue
            out[(r["dataset"], r["energy"], r["solver"])] = r
        return out


def targets(runs):
    """The targets of the runs' columns, loosest first."""
    taus = set()
    for r in runs.values():
        taus.update(k[len("iters_to_"):] for k in r if k.startswith("iters_to_"))
    return sorted(taus, key=float, reverse=True)


def solved_at(r, tau):
    return bool(r.get(f"iters_to_{tau}"))


def counts(runs, keys, taus):
    """Per solver: runs, solved (the verdict: at its energy's tightest target), reached each
    target (`iters_to_<tau>` filled), and each verdict that is not `solved`."""
    out = collections.OrderedDict()
    for k in sorted(keys, key=lambda k: k[2]):
        r = runs[k]
        c = out.setdefault(k[2], collections.Counter())
        c["runs"] += 1
        for tau in taus:
            c[f"at {tau}"] += solved_at(r, tau)
        c[r.get("verdict") or "not judged"] += 1
    return out


def table(before, after, energy):
    b = {k: r for k, r in before.items() if energy in (None, k[1])}
    a = {k: r for k, r in after.items() if energy in (None, k[1])} if after is not None else None
    keys = set(b) & set(a) if a is not None else set(b)
    taus = targets(b) if a is None else sorted(set(targets(b)) | set(targets(a)), key=float, reverse=True)
    cb = counts(b, keys, taus)
    ca = counts(a, keys, taus) if a is not None else None
    verdicts = sorted({v for c in list(cb.values()) + list((ca or {}).values()) for v in c} -
                      {"runs", "solved"} - {f"at {t}" for t in taus})
    columns = ["runs", "solved"] + [f"at {t}" for t in taus] + verdicts
    print("| solver | " + " | ".join(c if not c.startswith("at ") else "reached " + c[3:] for c in columns) + " |")
    print("|---|" + "---:|" * len(columns))
    for solver in cb:
        cells = []
        for c in columns:
            x = cb[solver][c]
            cells.append(str(x) if ca is None else f"{x} → {ca[solver][c]}")
        print(f"| {solver} | " + " | ".join(cells) + " |")
    total = lambda c, k: sum(v[k] for v in c.values())
    cells = [str(total(cb, c)) if ca is None else f"{total(cb, c)} → {total(ca, c)}" for c in columns]
    print("| **all** | " + " | ".join(cells) + " |")


def ends(folder):
    runs = rows(folder)
    by = collections.defaultdict(lambda: [0, 0.0])
    for r in runs.values():
        by[r["stop_reason"]][0] += 1
        by[r["stop_reason"]][1] += float(r["time_s"] or 0.0)
    print(f"{folder}: {len(runs)} runs that ran, {sum(v[1] for v in by.values()):.0f} s of time_s")
    print("| end | runs | time_s |")
    print("|---|---:|---:|")
    for stop, (n, t) in sorted(by.items(), key=lambda x: -x[1][1]):
        print(f"| `{stop}` | {n} | {t:.0f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("before")
    ap.add_argument("after", nargs="?")
    ap.add_argument("--energy")
    ap.add_argument("--ends", action="store_true")
    a = ap.parse_args(argv)
    if a.ends:
        for folder in [a.before] + ([a.after] if a.after else []):
            ends(folder)
        return 0
    table(rows(a.before), rows(a.after) if a.after else None, a.energy)
    return 0


if __name__ == "__main__":
    sys.exit(main())
