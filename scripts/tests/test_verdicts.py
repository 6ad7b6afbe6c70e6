"""scripts/verdicts.py: the per-solver before → after table and the ends' counts and times."""

import csv
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import verdicts  # noqa: E402

COLUMNS = ["dataset", "energy", "solver", "status", "verdict", "stop_reason", "time_s", "iters_to_1e-3", "iters_to_1e-6"]


def folder(tmp_path, name, rows):
    d = tmp_path / name
    d.mkdir()
    with open(d / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        w.writerows(rows)
    return str(d)


def test_before_and_after_per_solver_on_the_runs_both_have(tmp_path, capsys):
    before = folder(tmp_path, "before", [
        ["m", "sd", "kp", "not_converged", "stopped_above_target", "grad_tol", "1.0", "5", ""],
        ["m", "sd", "gd", "not_converged", "unfinished", "max_iters", "2.0", "", ""],
        ["m", "bconf", "gd", "skipped", "", "", "", "", ""],
    ])
    after = folder(tmp_path, "after", [
        ["m", "sd", "kp", "ok", "solved", "target", "1.5", "5", "7"],
        ["m", "sd", "gd", "not_converged", "stalled", "no_decrease", "3.0", "9", ""],
        ["n", "sd", "kp", "ok", "solved", "target", "1.0", "1", "2"],
    ])
    assert verdicts.main([before, after]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("| solver | runs | solved | reached 1e-3 | reached 1e-6 | stalled | stopped_above_target "
                      "| unfinished |")
    # the skipped run and the run only `after` has are left out
    assert "| gd | 1 → 1 | 0 → 0 | 0 → 1 | 0 → 0 | 0 → 1 | 0 → 0 | 1 → 0 |" in out
    assert "| kp | 1 → 1 | 0 → 1 | 1 → 1 | 0 → 1 | 0 → 0 | 1 → 0 | 0 → 0 |" in out
    assert out[-1] == "| **all** | 2 → 2 | 0 → 1 | 1 → 2 | 0 → 1 | 0 → 1 | 1 → 0 | 1 → 0 |"


def test_the_ends_count_runs_and_sum_their_times(tmp_path, capsys):
    after = folder(tmp_path, "after", [
        ["m", "sd", "kp", "ok", "solved", "target", "1.5", "5", "7"],
        ["n", "sd", "kp", "ok", "solved", "target", "1.0", "1", "2"],
        ["m", "sd", "gd", "not_converged", "unfinished", "max_iters", "3.0", "", ""],
    ])
    assert verdicts.main(["--ends", after]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("3 runs that ran, 6 s of time_s")
    assert out[3:] == ["| `max_iters` | 1 | 3 |", "| `target` | 2 | 2 |"]
