"""Tests of scripts/fresh_clone.py's pure part (run by .ci/run):

    python -m pytest scripts/tests
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fresh_clone as fc  # noqa: E402

LOG = """== cargo fmt --check [01:00:00, +0s]
Checking...
== cargo clippy [01:00:02, +2s]
== cargo test --release --all-targets (the README's test command) [01:05:00, +300s]
test result: ok.
== done [01:20:00, +1200s]
"""


def test_each_step_lasts_until_the_next_header_and_done_takes_none():
    assert fc.step_times(LOG) == [
        ("cargo fmt --check", 2),
        ("cargo clippy", 298),
        ("cargo test --release --all-targets (the README's test command)", 900),
    ]


def test_a_log_cut_short_ends_its_last_step_at_the_total_when_given():
    cut = "\n".join(LOG.splitlines()[:3])
    assert fc.step_times(cut) == [("cargo fmt --check", 2)]
    assert fc.step_times(cut, total=310) == [("cargo fmt --check", 2), ("cargo clippy", 308)]
    assert fc.step_times("no headers here\n== not one [x]\n") == []


def test_minutes_round_to_the_second():
    assert (fc.minutes(59.4), fc.minutes(60), fc.minutes(386.6)) == ("59 s", "1 min 0 s", "6 min 27 s")
