#!/usr/bin/env python3
"""Time sparse Cholesky solvers on the Newton systems mapbench factorizes.

Export the systems first (the regularized KP matrix of each run, lower triangle):

    mapbench export-system configs/projection.toml --out target/systems --iteration 1

then time them, interleaved round by round so machine noise hits every solver alike:

    python3 scripts/bench_linear_solvers.py target/systems/*.mtx --rounds 5 [--threads 2]

Solvers (each on --threads threads, default 1; the ones whose packages are missing are skipped
with a note):
  mapbench-metis, mapbench-amd   `mapbench time-system --threads N` (mapbench's subtree-parallel
                                 factorization, analyse once, refactor)
  pardiso                        MKL Pardiso via pypardiso: mtype 2 (SPD), upper CSR,
                                 phases 11 / 22 / 33, MKL_NUM_THREADS=N
  cholmod-amd, cholmod-metis     CHOLMOD via scikit-sparse < 0.5 (Debian libsuitesparse-dev
                                 and libopenblas0-pthread, OPENBLAS_NUM_THREADS=N)

Prints median analyse / factorize / solve milliseconds per matrix and solver, and the ratio
of mapbench's numeric factorization to Pardiso's and CHOLMOD's (issue target: <= 1.0 x
Pardiso). Optional heavy wheels (pypardiso pulls ~315 MB of MKL): not part of CI.
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time



def threads_from(argv):
    """--threads N (or --threads=N) from the command line, before argparse runs: the vendor
    libraries read their thread counts when numpy/MKL/OpenBLAS load."""
    for i, a in enumerate(argv):
        if a == "--threads" and i + 1 < len(argv):
            return argv[i + 1]
        if a.startswith("--threads="):
            return a.split("=", 1)[1]
    return "1"


for var in ("MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ[var] = threads_from(sys.argv[1:])

import numpy as np  # noqa: E402
import scipy.io  # noqa: E402
import scipy.sparse as sp  # noqa: E402


def ms(t0):
    return 1e3 * (time.perf_counter() - t0)


def load(path):
    lower = scipy.io.mmread(path)
    if lower.shape[0] != lower.shape[1]:
        sys.exit(f"{path}: not square")
    lower = sp.tril(sp.csc_matrix(lower))
    rhs_path = path[: -len(".mtx")] + ".rhs.mtx" if path.endswith(".mtx") else None
    if rhs_path and os.path.exists(rhs_path):
        b = np.asarray(scipy.io.mmread(rhs_path)).ravel()
    else:
        b = np.ones(lower.shape[0])
    return lower, b


def time_mapbench(binary, path, ordering, repeat, threads):
    out = subprocess.run(
        [binary, "time-system", path, "--ordering", ordering, "--repeat", str(repeat), "--threads", str(threads)],
        check=True, capture_output=True, text=True,
    )
    t = json.loads(out.stdout)
    return t["analyse_ms"], t["factorize_ms"], t["solve_ms"]


def time_pardiso(lower, b, repeat):
    import pypardiso

    upper = sp.csr_matrix(lower.T)  # the lower CSC read as CSR: the upper triangle Pardiso wants
    upper.sort_indices()
    s = pypardiso.PyPardisoSolver(mtype=2)
    rhs = np.asfortranarray(b.reshape(-1, 1))
    s.set_phase(11)
    t0 = time.perf_counter()
    s._call_pardiso(upper, rhs)
    analyse = ms(t0)
    fact, solve = [], []
    for _ in range(repeat):
        s.set_phase(22)
        t0 = time.perf_counter()
        s._call_pardiso(upper, rhs)
        fact.append(ms(t0))
        s.set_phase(33)
        t0 = time.perf_counter()
        x = s._call_pardiso(upper, rhs)
        solve.append(ms(t0))
    check(lower, b, x.ravel(), "pardiso")
    s.set_phase(-1)
    s._call_pardiso(upper, rhs)
    return analyse, statistics.median(fact), statistics.median(solve)


def time_cholmod(lower, b, ordering, repeat):
    from sksparse.cholmod import analyze

    full = (lower + sp.tril(lower, -1).T).tocsc()
    t0 = time.perf_counter()
    factor = analyze(full, mode="supernodal", ordering_method=ordering)
    analyse = ms(t0)
    fact, solve = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        factor.cholesky_inplace(full)
        fact.append(ms(t0))
        t0 = time.perf_counter()
        x = factor(b)
        solve.append(ms(t0))
    check(lower, b, x, "cholmod")
    return analyse, statistics.median(fact), statistics.median(solve)


def check(lower, b, x, name):
    full = lower + sp.tril(lower, -1).T
    res = np.linalg.norm(full @ x - b) / max(np.linalg.norm(b), 1e-300)
    if not res < 1e-8:
        sys.exit(f"{name}: relative residual {res:.2e}")


def available(module):
    try:
        __import__(module)
        return True
    except ImportError:
        return False


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("matrices", nargs="+", help="*.mtx files from `mapbench export-system`")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds (medians over rounds)")
    ap.add_argument("--repeat", type=int, default=3, help="factorizations per solver per round")
    ap.add_argument("--mapbench", default=shutil.which("mapbench") or "target/release/mapbench")
    ap.add_argument("--threads", type=int, default=1, help="threads of every solver (default 1)")
    args = ap.parse_args()
    if args.threads < 1 or str(args.threads) != os.environ["MKL_NUM_THREADS"]:
        sys.exit(f"--threads: give a whole number of threads, at least 1 (got {os.environ['MKL_NUM_THREADS']})")
    print(f"threads: {args.threads} (mapbench --threads, MKL/OpenBLAS/OpenMP *_NUM_THREADS)")

    solvers = {
        "mapbench-metis": lambda p, a, b: time_mapbench(args.mapbench, p, "metis", args.repeat, args.threads),
        "mapbench-amd": lambda p, a, b: time_mapbench(args.mapbench, p, "amd", args.repeat, args.threads),
    }
    if available("pypardiso"):
        solvers["pardiso"] = lambda p, a, b: time_pardiso(a, b, args.repeat)
    else:
        print("note: pypardiso not installed (pip install pypardiso); Pardiso skipped")
    if available("sksparse"):
        solvers["cholmod-amd"] = lambda p, a, b: time_cholmod(a, b, "amd", args.repeat)
        solvers["cholmod-metis"] = lambda p, a, b: time_cholmod(a, b, "metis", args.repeat)
    else:
        print("note: scikit-sparse not installed (pip install 'scikit-sparse<0.5'); CHOLMOD skipped")

    results = {}  # (matrix, solver) -> list of (analyse, factorize, solve)
    systems = {p: load(p) for p in args.matrices}
    for r in range(args.rounds):
        for p, (a, b) in systems.items():
            for name, run in solvers.items():
                results.setdefault((p, name), []).append(run(p, a, b))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)

    print(f"\n{'matrix':<48} {'n':>8} {'solver':<15} {'analyse':>9} {'factor':>9} {'solve':>8}  (ms, medians)")
    for p, (a, _) in systems.items():
        med = {}
        for name in solvers:
            runs = results[(p, name)]
            med[name] = [statistics.median(x[k] for x in runs) for k in range(3)]
            an, fa, so = med[name]
            print(f"{os.path.basename(p):<48} {a.shape[0]:>8} {name:<15} {an:>9.1f} {fa:>9.1f} {so:>8.1f}")
        for ours in ("mapbench-metis", "mapbench-amd"):
            for ref in ("pardiso", "cholmod-metis", "cholmod-amd"):
                if ref in med:
                    # Median of per-round ratios: robust to a noisy round.
                    ratios = [x[1] / y[1] for x, y in zip(results[(p, ours)], results[(p, ref)])]
                    print(f"{'':<48} {'':>8} {ours}/{ref} factorize: {statistics.median(ratios):.2f}")


if __name__ == "__main__":
    main()
