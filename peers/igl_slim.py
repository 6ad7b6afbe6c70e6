#!/usr/bin/env python3
"""libigl's SLIM (Rabinovich, Poranne, Panozzo and Sorkine-Hornung 2017) through PyPI's
`libigl`, under mapbench's external-solver protocol (peers/PROTOCOL.md): `param` with `sd`,
free boundary, from the problem's start map; one `slim_solve` iteration per record.

The energy recorded is mapbench's (`Problem.sd`: the area-weighted mean of
1/2 (|J|^2 + |J^-1|^2) on the area-1 mesh), computed here from the map: libigl's own
`SYMMETRIC_DIRICHLET` objective is the area-weighted sum of |J|^2 + |J^-1|^2, twice ours on an
area-1 mesh, and the Python binding does not expose it. SLIM has no gradient to report.

With targets (`problem.json`'s `targets`) it runs on to the tightest, as mapbench's own runs do:
the papers' rule (`energy_decrease_tol`) is an event the harness marks on the records, not an
end. It ends at the target, when the lowest energy fell by no more than round-off over the
problem's `stall_window` (`no_decrease`), when an iteration raises the energy beyond round-off
(`line_search_failed`), or at `max_iters`. Without targets it also stops at the rule: when an
iteration lowers the energy by less than `energy_decrease_tol` (absolute, `E_old - E_new <
tol`, as the protocol says), or by less than 1e-10 of the energy (SLIM's relative rule) when
that is 0 (`converged`). The `decrease` it records is the relative one.

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
    rules_end = p.target_energy is None
    rtol = p.stall.rtol
    max_iters = int(p.stop["max_iters"])
    reason = "max_iters"
    p.stall.push(energy)
    for k in range(1, max_iters + 1):
        uv = np.asarray(igl.slim_solve(data, 1), dtype=np.float64)
        new = p.sd(uv)
        if not np.isfinite(new):
            # JSON has no infinity: the run fails with what happened, not with a bad record
            p.finish("error", f"iteration {k}: SLIM's map inverts a face (SD not finite)")
            return 0
        decrease = (energy - new) / abs(energy)
        rule = energy - new < absolute if absolute > 0 else decrease < 1e-10
        # a rise within round-off is no breakdown where the stall decides
        rose = new - energy > rtol * max(1.0, abs(energy)) if rtol > 0 else decrease <= 0
        energy = new
        reached = p.at_target(energy)
        stalled = p.stall.push(energy)
        if reached:
            reason = "target"
        elif rose:
            reason = "line_search_failed"
        elif stalled:
            reason = "no_decrease"
        elif rule and rules_end:
            reason = "converged"
        done = k == max_iters or reason != "max_iters"
        p.record(k, energy, uv, final=done, decrease=decrease)
        if done:
            break
    p.finish(reason)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[-1]))
