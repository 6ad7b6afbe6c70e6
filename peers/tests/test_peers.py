"""The Python side of the external-solver protocol: mapbench's SD convention against closed
forms, the template's gradient against finite differences, and both adapters end to end on a
problem folder (records, snapshots, result).

Without numpy (all of it) or libigl (the igl_slim.py case) the tests are skipped naming the
install command, unless MAPBENCH_REQUIRE_PEERS is set (.ci/run sets it): then they fail."""
import importlib.util
import json
import os
import subprocess
import sys

import pytest

INSTALL = "python3 -m pip install -r peers/requirements.txt"
REQUIRED = "MAPBENCH_REQUIRE_PEERS" in os.environ
if importlib.util.find_spec("numpy") is None and not REQUIRED:
    pytest.skip(f"python3 has no numpy for the Python peers ({INSTALL})", allow_module_level=True)
HAS_IGL = importlib.util.find_spec("igl") is not None

import numpy as np  # noqa: E402

PEERS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, PEERS)

from example_gd import sd_gradient  # noqa: E402
from mapbench_peer import Problem, read_uv, write_uv  # noqa: E402


def grid(n=5, side=1.0):
    V = np.array([[side * i / (n - 1), side * j / (n - 1), 0.0] for j in range(n) for i in range(n)])
    F = []
    for j in range(n - 1):
        for i in range(n - 1):
            v = j * n + i
            F += [[v, v + 1, v + n + 1], [v, v + n + 1, v + n]]
    return V, np.array(F)


def problem(tmp_path, start, max_iters=50, grad_tol=1e-6, V=None, F=None, energy_decrease_tol=0.0, targets=(),
            stall_window=0):
    if V is None:
        V, F = grid()
    os.makedirs(tmp_path, exist_ok=True)
    with open(tmp_path / "mesh.obj", "w") as f:
        f.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V.tolist())
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F.tolist())
    write_uv(str(tmp_path / "start.uv"), start)
    spec = {
        "protocol": 1,
        "task": "param",
        "energy": {"name": "sd"},
        "mesh": "mesh.obj",
        "start": "start.uv",
        "stop": {"max_iters": max_iters, "grad_tol": grad_tol, "energy_decrease_tol": energy_decrease_tol,
                 "grad_floor": 0.0, "stall_window": stall_window, "stall_rtol": 1e-12 if stall_window else 0.0},
        "snapshot_every": 4,
        "targets": [{"tau": tau, "energy": e} for tau, e in targets],
    }
    (tmp_path / "problem.json").write_text(json.dumps(spec))
    return str(tmp_path)


def distorted(V):
    """A smooth, injective distortion of the grid's plane."""
    x, y = V[:, 0], V[:, 1]
    return np.stack([x + 0.15 * np.sin(3 * y), y + 0.1 * x * x], 1)


def test_sd_is_two_at_isometries_closed_form_at_scalings_and_inf_when_inverted(tmp_path):
    V, F = grid(side=1.0)
    p = Problem(problem(tmp_path, V[:, :2], V=V, F=F))
    theta = 0.7
    R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    assert p.sd(V[:, :2] @ R.T + 3.0) == pytest.approx(2.0, abs=1e-13)
    # a uniform scaling by s: (s^2)(1 + s^-4) = s^2 + s^-2
    assert p.sd(2.0 * V[:, :2]) == pytest.approx(4.25, abs=1e-12)
    assert p.sd(V[:, :2] * np.array([-1.0, 1.0])) == float("inf")


def test_the_templates_gradient_matches_central_differences(tmp_path):
    V, F = grid()
    p = Problem(problem(tmp_path, distorted(V)))
    uv = distorted(V)
    g = sd_gradient(p, uv)
    h = 1e-6
    for k in range(0, uv.size, 7):
        e = np.zeros(uv.size)
        e[k] = h
        e = e.reshape(uv.shape)
        fd = (p.sd(uv + e) - p.sd(uv - e)) / (2 * h)
        assert fd == pytest.approx(g.flat[k], abs=1e-7, rel=1e-6), k


def test_the_handles_penalty_and_its_gradient(tmp_path):
    """deform's objective: SD plus lambda * sum |x_v - target|^2; the gradient against central
    differences, a handle at its target costs nothing."""
    V, F = grid()
    folder = problem(tmp_path, distorted(V))
    spec = json.loads((tmp_path / "problem.json").read_text())
    spec["task"] = "deform"
    spec["handles"] = {"lambda": 3.0, "vertices": [0, 7, 7], "targets": [[0.1, 0.2], [0.5, -0.5], [0.0, 0.0]]}
    (tmp_path / "problem.json").write_text(json.dumps(spec))
    p = Problem(folder)
    uv = distorted(V)
    d0, d7 = uv[0] - [0.1, 0.2], uv[7] - [0.5, -0.5]
    assert p.penalty(uv) == pytest.approx(3.0 * (d0 @ d0 + d7 @ d7 + uv[7] @ uv[7]), rel=1e-14)
    assert p.objective(uv) == pytest.approx(p.sd(uv) + p.penalty(uv), rel=1e-15)
    g = p.penalty_gradient(uv)
    h = 1e-6
    for k in range(uv.size):
        e = np.zeros(uv.size)
        e[k] = h
        e = e.reshape(uv.shape)
        fd = (p.penalty(uv + e) - p.penalty(uv - e)) / (2 * h)
        assert fd == pytest.approx(g.flat[k], abs=1e-8), k
    at = uv.copy()
    at[0] = [0.1, 0.2]
    assert p.penalty_gradient(at)[0] == pytest.approx([0.0, 0.0])


@pytest.mark.parametrize("adapter", [
    "example_gd.py",
    pytest.param("igl_slim.py", marks=pytest.mark.skipif(
        not HAS_IGL and not REQUIRED, reason=f"python3 has no libigl ({INSTALL})")),
])
def test_an_adapter_writes_records_snapshots_and_a_result(tmp_path, adapter):
    V, F = grid(7)
    folder = problem(tmp_path, distorted(V), max_iters=40, V=V, F=F)
    done = subprocess.run([sys.executable, os.path.join(PEERS, adapter), folder], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = [json.loads(line) for line in open(os.path.join(folder, "iterations.jsonl"))]
    assert [r["iter"] for r in rows] == list(range(len(rows)))
    energies = [r["energy"] for r in rows]
    assert all(b <= a for a, b in zip(energies, energies[1:])), energies
    assert energies[-1] < energies[0] and energies[-1] >= 2.0
    result = json.load(open(os.path.join(folder, "result.json")))
    assert result["stop_reason"] in ("converged", "max_iters", "line_search_failed", "no_decrease")
    snaps = sorted(int(n[:-3]) for n in os.listdir(os.path.join(folder, "maps")))
    last = rows[-1]["iter"]
    assert snaps == sorted({0, last} | set(range(4, last + 1, 4))), snaps
    # every snapshot is the map of the energy recorded at its iteration, in mapbench's convention
    p = Problem(folder)
    for k in snaps:
        assert p.sd(read_uv(os.path.join(folder, "maps", f"{k}.uv"))) == energies[k]


@pytest.mark.skipif(not HAS_IGL and not REQUIRED, reason=f"python3 has no libigl ({INSTALL})")
def test_igl_slim_reads_the_energy_decrease_tolerance_as_absolute(tmp_path):
    """The protocol's `energy_decrease_tol` is absolute, `E_old - E_new < tol`, as the harness
    passes it: SLIM stops at the first step that lowers the energy by less than 1e-4 (on this
    grid, near SD = 2, a relative reading would stop a step earlier, at a decrease of 1.3e-4)."""
    V, F = grid(7)
    folder = problem(tmp_path, distorted(V), max_iters=200, V=V, F=F, energy_decrease_tol=1e-4)
    done = subprocess.run([sys.executable, os.path.join(PEERS, "igl_slim.py"), folder], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    energies = [json.loads(line)["energy"] for line in open(os.path.join(folder, "iterations.jsonl"))]
    decreases = [a - b for a, b in zip(energies, energies[1:])]
    assert json.load(open(os.path.join(folder, "result.json")))["stop_reason"] == "converged"
    assert decreases[-1] < 1e-4 <= min(decreases[:-1]), decreases
    assert decreases[-2] < 1e-4 * energies[-2], "a relative reading would have stopped here"


def test_a_stall_is_no_decrease_of_the_lowest_energy_beyond_round_off_over_the_window():
    from mapbench_peer import Stall
    stall = Stall(3, 1e-12)
    # a rise does not count against it; the lowest energy 3 iterations back is the one now
    assert [stall.push(e) for e in [3.0, 2.0, 2.0 + 1e-15, 2.0 - 1e-13, 2.0]] == [False] * 4 + [True]
    falling = Stall(3, 1e-12)
    assert not any(falling.push(e) for e in [3.0, 2.5, 2.2, 2.1, 2.05])
    off = Stall(0, 0.0)
    assert not any(off.push(2.0) for _ in range(10))


def slim(folder):
    done = subprocess.run([sys.executable, os.path.join(PEERS, "igl_slim.py"), folder], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    energies = [json.loads(line)["energy"] for line in open(os.path.join(folder, "iterations.jsonl"))]
    return energies, json.load(open(os.path.join(folder, "result.json")))["stop_reason"]


@pytest.mark.skipif(not HAS_IGL and not REQUIRED, reason=f"python3 has no libigl ({INSTALL})")
def test_igl_slim_with_a_target_goes_past_the_rule_to_the_target_or_a_stall(tmp_path):
    """With targets the papers' rule is the harness's event, not an end: SLIM goes on past the
    first step that lowers the energy by less than 1e-4 (where it stops without targets, the
    test above), to the target; below any SD (1.0) it ends at the stall, which the records
    show."""
    V, F = grid(7)
    rule, _ = slim(problem(tmp_path / "rule", distorted(V), max_iters=200, V=V, F=F, energy_decrease_tol=1e-4))
    low = rule[-1] - 1e-9
    reached, why = slim(problem(tmp_path / "target", distorted(V), max_iters=200, V=V, F=F, energy_decrease_tol=1e-4,
                                targets=[(1e-3, rule[-1]), (1e-6, low)], stall_window=50))
    assert why == "target" and reached[-1] <= low < reached[-2], reached[-3:]
    assert len(reached) > len(rule)
    below, why = slim(problem(tmp_path / "stall", distorted(V), max_iters=1000, V=V, F=F, energy_decrease_tol=1e-4,
                              targets=[(1e-6, 1.0)], stall_window=50))
    assert why == "no_decrease", (len(below), below[-3:])
    lowest = np.minimum.accumulate(below)
    assert lowest[-51] - lowest[-1] <= 1e-12 * lowest[-1] and lowest[-52] - lowest[-2] > 1e-12 * lowest[-2]
