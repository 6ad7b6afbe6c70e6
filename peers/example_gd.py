#!/usr/bin/env python3
"""A template for your own solver under mapbench's external-solver protocol
(peers/PROTOCOL.md): gradient descent with backtracking on the symmetric Dirichlet energy,
in numpy. Copy this file and `mapbench_peer.py`, replace `step` with your method, and name the
command in a config (file names are relative to its folder; here, a config in `configs/`):

    [external.my-gd]
    command = ["python3", "../peers/example_gd.py"]
    tasks = ["param", "deform"]
    energies = ["sd"]

mapbench recomputes the energy of every map you snapshot with its own code, so report the
energy in its convention (`Problem.objective`: SD, 2 at an isometry, plus the handles' penalty
in deform) and snapshot the map you report.
"""
import sys

import numpy as np

from mapbench_peer import Problem, wirtinger


def sd_gradient(p, uv):
    """The gradient of `Problem.sd` with respect to the map (n x 2), by the chain rule through
    f_z and f_zbar: dpsi/dfz = 2 a1 fz, dpsi/dfzbar = 2 a2 fzbar (complex-view paper, Table 2)."""
    l1, (x2, y2), area = p.rest
    F = p.F
    fz, fzb = wirtinger(p.rest, uv, F)
    x, y = np.sum(fz * fz, 1), np.sum(fzb * fzb, 1)
    d3 = (x - y) ** 3
    w = (area / area.sum())[:, None]
    gz = w * 2.0 * (1.0 - (x + 3.0 * y) / d3)[:, None] * fz
    gzb = w * 2.0 * (1.0 + (3.0 * x + y) / d3)[:, None] * fzb
    # d/dJ of the density through fz = (j00 + j11, j10 - j01)/2, fzb = (j00 - j11, j10 + j01)/2
    g00 = 0.5 * (gz[:, 0] + gzb[:, 0])
    g11 = 0.5 * (gz[:, 0] - gzb[:, 0])
    g10 = 0.5 * (gz[:, 1] + gzb[:, 1])
    g01 = 0.5 * (-gz[:, 1] + gzb[:, 1])
    # J's columns from the edges: col1 = a / l1, col2 = (b - col1 x2) / y2
    gb = np.stack([g01, g11], 1) / y2[:, None]
    ga = (np.stack([g00, g10], 1) - gb * x2[:, None]) / l1[:, None]
    grad = np.zeros_like(uv)
    np.add.at(grad, F[:, 1], ga)
    np.add.at(grad, F[:, 2], gb)
    np.add.at(grad, F[:, 0], -ga - gb)
    return grad


def step(p, uv, energy, grad):
    """Backtracking (Armijo) along -grad from t = 1; None when no step decreases the energy."""
    t, slope = 1.0, float(np.sum(grad * grad))
    while t > 1e-20:
        trial = uv - t * grad
        e = p.objective(trial)
        if e <= energy - 1e-4 * t * slope:
            return trial, e
        t *= 0.5
    return None


def main(folder):
    p = Problem(folder)
    if p.energy["name"] != "sd":
        p.finish("error", "example_gd minimizes sd only")
        return 2
    uv, energy = p.start, p.objective(p.start)
    max_iters, tol = int(p.stop["max_iters"]), float(p.stop["grad_tol"])
    grad = sd_gradient(p, uv) + p.penalty_gradient(uv)
    norm, k = float(np.linalg.norm(grad)), 0

    # With a target, go on to it (the gradient rule is mapbench's event to record); without
    # one, stop at the rule. Either way a stall (no decrease beyond round-off over the
    # problem's window) ends it.
    def done():
        return p.at_target(energy) if p.target_energy is not None else norm <= tol

    stalled = p.stall.push(energy)
    p.record(0, energy, uv, final=done() or stalled or max_iters == 0, own_grad_norm=norm)
    while not done() and not stalled and k < max_iters:
        moved = step(p, uv, energy, grad)
        if moved is None:
            p.snapshot(k, uv)
            p.finish("line_search_failed")
            return 0
        (uv, energy), k = moved, k + 1
        grad = sd_gradient(p, uv) + p.penalty_gradient(uv)
        norm = float(np.linalg.norm(grad))
        stalled = p.stall.push(energy)
        p.record(k, energy, uv, final=done() or stalled or k == max_iters, own_grad_norm=norm)
    if p.at_target(energy):
        p.finish("target")
    elif stalled:
        p.finish("no_decrease")
    else:
        p.finish("converged" if norm <= tol else "max_iters")
    return 0

if __name__ == "__main__":
    sys.exit(main(sys.argv[-1]))
