"""The solver side of mapbench's external-solver protocol (docs: peers/PROTOCOL.md), for
Python adapters: read the problem folder, score a map in mapbench's convention, write the
iteration records, the snapshots and the result.

numpy only. A map is an (n, 2) float64 array in the problem's frame (the mesh as mapbench
normalized it: centred, area 1).
"""
import json
import os
import time

import numpy as np


class Problem:
    """A problem folder: `problem.json`, `mesh.obj`, `start.uv`."""

    def __init__(self, folder):
        self.folder = folder
        with open(os.path.join(folder, "problem.json")) as f:
            self.spec = json.load(f)
        self.V, self.F = read_obj(os.path.join(folder, self.spec["mesh"]))
        self.start = read_uv(os.path.join(folder, self.spec["start"]))
        self.energy = self.spec["energy"]
        self.stop = self.spec["stop"]
        # The verdict's targets as energies, loosest first; a solver may stop at the last
        # (`finish("target")`), as mapbench's own runs do. None without a reference minimum.
        targets = self.spec.get("targets") or []
        self.target_energy = float(targets[-1]["energy"]) if targets else None
        self.snapshot_every = int(self.spec.get("snapshot_every", 0))
        # No decrease beyond round-off over `stall_window` iterations: stationary, as mapbench's
        # own runs end (`finish("no_decrease")`; mapbench checks it on the records).
        self.stall = Stall(int(self.stop.get("stall_window", 0)), float(self.stop.get("stall_rtol", 0.0)))
        self.rest = rest_frames(self.V, self.F)
        # deform: soft handles, lambda * sum |x_v - target|^2 added to the energy
        h = self.spec.get("handles")
        self.lam = float(h["lambda"]) if h else 0.0
        self.handle_vertices = np.array(h["vertices"] if h else [], dtype=np.int64)
        self.handle_targets = np.array(h["targets"] if h else [], dtype=np.float64).reshape(-1, 2)
        self._records = open(os.path.join(folder, "iterations.jsonl"), "w")
        os.makedirs(os.path.join(folder, "maps"), exist_ok=True)
        self.clock0 = time.perf_counter()
        # Time spent writing records and snapshots, kept off the solver's clock.
        self._io_s = 0.0
        self._io_unreported = 0.0

    def sd(self, uv):
        """Symmetric Dirichlet in mapbench's convention: the area-weighted mean of
        1/2 (|J|^2 + |J^-1|^2), 2 at an isometry, inf when a face is inverted."""
        x, y = wirtinger_xy(self.rest, uv, self.F)
        d = x - y
        if np.any(~(d > 0)):
            return float("inf")
        area = self.rest[2]
        return float(np.sum(area * (x + y) * (1.0 + 1.0 / (d * d))) / np.sum(area))

    def objective(self, uv):
        """The problem's energy in mapbench's convention: `sd`, plus the handles' penalty for
        `deform`."""
        return self.sd(uv) + self.penalty(uv)

    def penalty(self, uv):
        """lambda * sum |x_v - target|^2 over the handles (0 without any)."""
        d = np.asarray(uv)[self.handle_vertices] - self.handle_targets
        return self.lam * float(np.sum(d * d))

    def penalty_gradient(self, uv):
        """The penalty's gradient (n x 2): 2 lambda (x_v - target) at each handle."""
        g = np.zeros_like(np.asarray(uv, dtype=np.float64))
        np.add.at(g, self.handle_vertices, 2.0 * self.lam * (np.asarray(uv)[self.handle_vertices] - self.handle_targets))
        return g

    def record(self, iteration, energy, uv, final=False, **extras):
        """One line of `iterations.jsonl` and the map at iteration 0, every `snapshot_every`
        and at the end. `time_s` is this process's clock since the Problem was read, less the
        time spent writing records and snapshots; `record_s` is that writing time since the
        previous line (mapbench leaves it out of the run's time too)."""
        t = time.perf_counter()
        row = {"iter": int(iteration), "energy": float(energy), "time_s": t - self.clock0 - self._io_s}
        row["record_s"] = self._io_unreported
        row.update(extras)
        self._records.write(json.dumps(row) + "\n")
        self._records.flush()
        every = self.snapshot_every
        if iteration == 0 or final or (every > 0 and iteration % every == 0):
            self.snapshot(iteration, uv)
        spent = time.perf_counter() - t
        self._io_s += spent
        self._io_unreported = spent

    def snapshot(self, iteration, uv):
        """`maps/<iteration>.uv`: the map of a recorded iteration (also the final one when the
        solver learns only afterwards that it was the last)."""
        write_uv(os.path.join(self.folder, "maps", f"{int(iteration)}.uv"), uv)

    def at_target(self, energy):
        """Whether `energy` is at or below the tightest target (never without one)."""
        return self.target_energy is not None and energy <= self.target_energy

    def finish(self, stop_reason, message=""):
        """`result.json`: why the solver stopped (converged, target, no_decrease, grad_floor,
        max_iters, line_search_failed, timeout, error)."""
        self._records.close()
        with open(os.path.join(self.folder, "result.json"), "w") as f:
            json.dump({"stop_reason": stop_reason, "message": message}, f)


class Stall:
    """Whether the lowest energy so far fell by no more than `rtol * max(1, |E|)` over the last
    `window` iterations (never with a window of 0), as mapbench tells a stall. Push every
    recorded energy, iteration 0's too."""

    def __init__(self, window, rtol):
        self.window, self.rtol, self.best = window, rtol, []

    def push(self, energy):
        if self.window <= 0:
            return False
        best = min(energy, self.best[-1]) if self.best else energy
        self.best = (self.best + [best])[-(self.window + 1):]
        return len(self.best) > self.window and self.best[0] - best <= self.rtol * max(1.0, abs(best))


def read_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                V.append([float(t) for t in p[1:4]])
            elif p[0] == "f":
                F.append([int(t.split("/")[0]) - 1 for t in p[1:4]])
    return np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)


def read_uv(path):
    return np.loadtxt(path, dtype=np.float64, ndmin=2)


def write_uv(path, uv):
    """One `u v` line per vertex, each value written so that it reads back exactly."""
    with open(path + ".tmp", "w") as f:
        f.write("".join(f"{float(u)!r} {float(v)!r}\n" for u, v in np.asarray(uv, dtype=np.float64)))
    os.replace(path + ".tmp", path)


def rest_frames(V, F):
    """Each face's edges in an orthonormal frame of its plane: (e1x, (e2x, e2y), area)."""
    p0, p1, p2 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    l1 = np.linalg.norm(e1, axis=1)
    u = e1 / l1[:, None]
    x2 = np.sum(e2 * u, axis=1)
    y2 = np.linalg.norm(e2 - x2[:, None] * u, axis=1)
    return l1, (x2, y2), 0.5 * l1 * y2


def wirtinger(rest, uv, F):
    """f_z and f_zbar (n x 2 each, as real pairs) of each face's Jacobian J, with J's
    entries: J [l1, 0]^T is the first edge's image, J [x2, y2]^T the second's."""
    l1, (x2, y2), _ = rest
    a = uv[F[:, 1]] - uv[F[:, 0]]
    b = uv[F[:, 2]] - uv[F[:, 0]]
    j00, j10 = a[:, 0] / l1, a[:, 1] / l1
    j01, j11 = (b[:, 0] - j00 * x2) / y2, (b[:, 1] - j10 * x2) / y2
    fz = 0.5 * np.stack([j00 + j11, j10 - j01], axis=1)
    fzb = 0.5 * np.stack([j00 - j11, j10 + j01], axis=1)
    return fz, fzb


def wirtinger_xy(rest, uv, F):
    """x = |f_z|^2 and y = |f_zbar|^2 of each face's Jacobian (x < y when inverted)."""
    fz, fzb = wirtinger(rest, uv, F)
    return np.sum(fz * fz, axis=1), np.sum(fzb * fzb, axis=1)
