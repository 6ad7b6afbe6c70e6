#!/usr/bin/env python3
"""libigl's SLIM (Rabinovich, Poranne, Panozzo and Sorkine-Hornung 2017) through PyPI's
`libigl`, under mapbench's external-solver protocol (peers/PROTOCOL.md): `param` with `sd`,
free boundary, from the problem's start map; one `slim_solve` iteration per record.

The energy recorded is mapbench's (`Problem.sd`: the area-weighted mean of
1/2 (|J|^2 + |J^-1|^2) on the area-1 mesh), computed here from the map: libigl's own
`SYMMETRIC_DIRICHLET` objective is the area-weighted sum of |J|^2 + |J^-1|^2, twice ours on an
area-1 mesh, and the Python binding does not expose it. SLIM has no gradient to report; it
stops when an iteration lowers the energy by less than the problem's `energy_decrease_tol`
(absolute, `E_old - E_new < tol`, as the protocol says), or by less than 1e-10 of the energy
(its own relative rule) when that is 0, at `max_iters`, when an iteration does not decrease
the energy, or at the problem's tightest target (`targets`), as mapbench's own runs end there.
The `decrease` it records is the relative one.

    python3 peers/igl_slim.py PROBLEM_FOLDER
"""
import sys

import igl
import numpy as np

from mapbench_peer import Problem


def main(folder):
    p = Problem(folder)
    if p.spec["task"] != "param" or p.energy["name"] != "sd":
        p.finish("error", "igl-slim solves param with sd only")
        return 2
    uv = np.asfortranarray(p.start)
    energy = p.sd(uv)
    p.record(0, energy, uv, final=False)
    data = igl.slim_precompute(
        np.asfortranarray(p.V),
        np.asfortranarray(p.F.astype(np.int32)),
        uv,
        igl.MappingEnergyType.SYMMETRIC_DIRICHLET,
        np.zeros(0, dtype=np.int32),
        np.zeros((0, 2)),
        0.0,
    )
    # the problem's rule is absolute; without one, SLIM's own relative rule
    absolute = float(p.stop.get("energy_decrease_tol") or 0.0)
    max_iters = int(p.stop["max_iters"])
    reason = "max_iters"
    for k in range(1, max_iters + 1):
        uv = np.asarray(igl.slim_solve(data, 1), dtype=np.float64)
        new = p.sd(uv)
        if not np.isfinite(new):
            # JSON has no infinity: the run fails with what happened, not with a bad record
            p.finish("error", f"iteration {k}: SLIM's map inverts a face (SD not finite)")
            return 0
        decrease = (energy - new) / abs(energy)
        stalled = energy - new < absolute if absolute > 0 else decrease < 1e-10
        energy = new
        reached = p.at_target(energy)
        done = k == max_iters or decrease <= 0 or stalled or reached
        if reached:
            reason = "target"
        elif decrease <= 0:
            reason = "line_search_failed"
        elif stalled:
            reason = "converged"
        p.record(k, energy, uv, final=done, decrease=decrease)
        if done:
            break
    p.finish(reason)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[-1]))
