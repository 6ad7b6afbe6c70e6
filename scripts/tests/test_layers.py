"""scripts/layers.py: which crate's ranks apply, and the names that point up."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import layers  # noqa: E402


def crate(root, name, files):
    src = root / name / "src"
    for rel, text in files.items():
        path = src / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return str(src)


def test_the_ranks_are_the_crate_folders(tmp_path):
    src = crate(tmp_path, "solvers", {"lib.rs": ""})
    assert layers.ranks_of(src) is layers.SOLVERS_RANKS
    assert layers.ranks_of(src + "/") is layers.SOLVERS_RANKS
    assert layers.ranks_of(crate(tmp_path, "harness", {"lib.rs": ""})) is layers.HARNESS_RANKS


@pytest.mark.parametrize("where", ["other/src", "solvers/benches"])
def test_a_folder_without_ranks_is_refused_by_name(tmp_path, where):
    path = tmp_path / where
    path.mkdir(parents=True)
    with pytest.raises(SystemExit) as refused:
        layers.ranks_of(str(path))
    assert str(path) in str(refused.value) and "RANKS_OF" in str(refused.value)


def test_a_name_up_the_layers_is_reported(tmp_path, capsys):
    src = crate(tmp_path, "solvers", {
        "lib.rs": "pub mod linear;\npub mod tasks;\n",
        "linear.rs": "use crate::tasks::Task;\npub struct Cholesky;\n",
        "tasks.rs": "use crate::linear::Cholesky;\npub enum Task {}\n",
    })
    assert layers.main([src]) == 1
    out = capsys.readouterr().out
    assert "linear.rs: names crate::tasks" in out and "1 upward name(s)" in out


def test_names_down_the_layers_and_in_unit_tests_pass(tmp_path, capsys):
    src = crate(tmp_path, "solvers", {
        "lib.rs": "pub mod linear;\npub mod tasks;\n",
        "linear.rs": "pub struct Cholesky;\n#[cfg(test)]\nmod tests {\n    use crate::tasks::Task;\n}\n",
        "tasks.rs": "use crate::linear::Cholesky;\npub enum Task {}\n",
    })
    assert layers.main([src]) == 0
    assert "0 upward name(s)" in capsys.readouterr().out
