#!/usr/bin/env python3
"""Each crate's modules point one way: each top-level module of harness/src and of
solvers/src has a layer rank, and a file may name (by a `crate::`, `super::` or `self::`
path, or a child module named without a prefix; the parsing of scripts/import_cycles.py)
only modules of its own rank or below. The harness:

    0  leaves        hash, paths, stats, names, escape, convergence, signals, calibration, utc,
                     family
    1  run_folder    every file of a run folder, meta.json typed and versioned
    2  the batch     plan, run, judge, history, gate, export, output, evaluate, external, slurm,
                     corpus, claims
    3  report        tables, plots, the report and trend pages, the comparison page
    4  edges         cli (the binary) and fuzzing (what the fuzz targets call)

The numerics crate (solvers), in wings; nothing below the tasks names a task:

    0  leaves        grouping; linear: sparse Cholesky, triangular solves, orderings and
                     their errors, on any lower CSC pattern (`LowerPattern`)
    1  the mesh      mesh (with topology, validation, handles) and generate
    2  the element   energy, local, hessian, smoothness, assembly, laplacian, problem, init,
                     line_search: an element's energy, derivatives and Hessian blocks, the
                     assembled problem and its start
    3  solver        the executor and the solvers' steps (Newton, L-BFGS, AQP, proxies)
    4  tasks         param, deform, authalic, the Newton system of a run, the catalogue

A rank is what a module is, not the least its imports allow: calibration names only stats,
output names run_folder (whose files it refuses to overwrite) and so sits with the batch,
and fuzzing, an entry point like cli, is an edge that nothing in the library may name. The
binary reaches the library through `mapbench::` paths, which are not followed: cli is the
top.

Modules of one rank may use each other, but not in a circle (a circle of files is
scripts/import_cycles.py's to find; here a circle of top-level modules is refused too).
Test code is left out, as import_cycles.py does: a file's `#[cfg(test)] mod { ... }` (its
unit tests, at its end) and a module's test file (`#[cfg(test)] mod tests;`, `tests.rs`),
since tests may drive a module through the layers above it. A new top-level module must be
given a rank here.

    python3 scripts/layers.py [CRATE_SRC ...]   (default: harness/src solvers/src)

Prints each offending file with the path it names and exits 1 when there is any.
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from import_cycles import modules, named, sccs, strip_comments  # noqa: E402

HARNESS_RANKS = {
    "hash": 0,
    "paths": 0,
    "stats": 0,
    "names": 0,
    "escape": 0,
    "convergence": 0,
    "signals": 0,
    "calibration": 0,
    "hardware": 0,
    "column_names": 0,
    "utc": 0,
    "family": 0,
    "run_folder": 1,
    "plan": 2,
    "run": 2,
    "judge": 2,
    "history": 2,
    "gate": 2,
    "export": 2,
    "output": 2,
    "evaluate": 2,
    "external": 2,
    "slurm": 2,
    "corpus": 2,
    "claims": 2,
    "report": 3,
    "cli": 4,
    "fuzzing": 4,
}

SOLVERS_RANKS = {
    "grouping": 0,
    "linear": 0,
    "mesh": 1,
    "generate": 1,
    "energy": 2,
    "local": 2,
    "hessian": 2,
    "smoothness": 2,
    "assembly": 2,
    "laplacian": 2,
    "problem": 2,
    "init": 2,
    "line_search": 2,
    "test_support": 2,
    "solver": 3,
    "tasks": 4,
}

# Each crate's ranks, by the crate's folder (the parent of its `src`).
RANKS_OF = {"harness": HARNESS_RANKS, "solvers": SOLVERS_RANKS}

TEST_MOD = re.compile(
    r"#\[cfg\(test\)\]\s*(?:#\[path\s*=\s*\"([\w/]+)\.rs\"\]\s*)?(?:pub(?:\([a-z]+\))?\s+)?mod\s+(\w+)\s*;"
)


def test_files(mods):
    """The files of modules declared `#[cfg(test)] mod name;` (with or without `#[path =
    "x.rs"]`: `modules` keys such a file by its module's name), and of their submodules."""
    tests = set()
    for here, path in mods.items():
        for _file, name in TEST_MOD.findall(open(path, encoding="utf-8").read()):
            tests.add(here + (name,))
    return {path for key, path in mods.items() if any(key[: len(t)] == t for t in tests)}


def ranks_of(src):
    """The ranks of the crate whose `src` folder is `src`, by the crate's folder name."""
    crate = os.path.basename(os.path.dirname(os.path.abspath(src)))
    if os.path.basename(os.path.abspath(src)) != "src" or crate not in RANKS_OF:
        known = ", ".join(f"{c}/src" for c in RANKS_OF)
        raise SystemExit(f"{src}: not the src folder of a crate with ranks ({known}); add its ranks to RANKS_OF")
    return RANKS_OF[crate]


def main(srcs):
    return max(check(src, ranks_of(src)) for src in srcs)


def check(src, RANKS):
    mods = modules(src)
    skip = test_files(mods)
    top = {path: key[0] for key, path in mods.items() if key}
    unranked = sorted({m for m in top.values() if m not in RANKS})
    bad, edges = [], {}
    for here, path in sorted(mods.items()):
        if not here or path in skip:
            continue
        mine = here[0]
        text = strip_comments(open(path, encoding="utf-8").read())
        for written, target in named(text, here, mods):
            theirs = top.get(target)
            if theirs is None or theirs == mine or theirs in unranked or mine in unranked:
                continue
            edges.setdefault(mine, set()).add(theirs)
            if RANKS[theirs] > RANKS[mine]:
                bad.append((path, written, mine, theirs))
    for path, written, mine, theirs in sorted(set(bad)):
        print(f"{path}: names {written} ({theirs}, rank {RANKS[theirs]}) from {mine} (rank {RANKS[mine]})")
    circles = [sorted(c) for c in sccs({m: sorted(t) for m, t in edges.items()}) if len(c) > 1]
    for c in circles:
        print("modules in a circle: " + " ".join(c))
    for m in unranked:
        print(f"{src}/{m}: a top-level module without a rank (give it one in scripts/layers.py)")
    print(f"{len(set(bad))} upward name(s), {len(circles)} module circle(s), {len(unranked)} unranked module(s)")
    return 1 if bad or circles or unranked else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or ["harness/src", "solvers/src"]))
