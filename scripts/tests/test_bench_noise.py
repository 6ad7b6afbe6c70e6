"""Tests of scripts/bench_noise.py's pure part (run by .ci/run):

    python -m pytest scripts/tests
"""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import bench_noise as bn  # noqa: E402

HEADER = "dataset,energy,solver,status,time_s,time_norm\n"


def summary(tmp_path, name, rows):
    p = tmp_path / name
    p.write_text(HEADER + "".join(",".join(r) + "\n" for r in rows))
    return bn.read_summary(p)


def test_ratio_is_larger_over_smaller_and_refuses_non_positive_times():
    assert bn.ratio(2.0, 1.0) == bn.ratio(1.0, 2.0) == 2.0
    assert bn.ratio(0.0, 1.0) is None


def test_ratios_pair_runs_by_name_and_skip_untimed_or_failed_runs(tmp_path):
    a = summary(tmp_path, "a.csv", [
        ("m", "sd", "cm", "ok", "1.0", "2.0"),
        ("m", "sd", "kp", "not_converged", "3.0", "6.0"),
        ("m", "sd", "slim", "failed", "", ""),
        ("only_a", "sd", "cm", "ok", "1.0", "1.0"),
    ])
    b = summary(tmp_path, "b.csv", [
        ("m", "sd", "cm", "ok", "1.5", "2.2"),
        ("m", "sd", "kp", "ok", "2.0", "6.6"),
        ("m", "sd", "slim", "skipped", "", ""),
    ])
    raw = bn.ratios(a, b, "time_s")
    assert raw == {("m", "sd", "cm"): pytest.approx(1.5), ("m", "sd", "kp"): pytest.approx(1.5)}
    norm = bn.ratios(a, b, "time_norm")
    assert norm == {("m", "sd", "cm"): pytest.approx(1.1), ("m", "sd", "kp"): pytest.approx(1.1)}
