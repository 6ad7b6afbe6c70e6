"""scripts/import_cycles.py: which paths are arrows, and the circles they close."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import import_cycles  # noqa: E402


def crate(tmp_path, files):
    for rel, text in files.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return str(tmp_path)


def test_a_parent_that_re_exports_a_child_which_uses_the_parent_is_a_circle(tmp_path, capsys):
    src = crate(tmp_path, {
        "lib.rs": "pub mod energy;\n",
        "energy/mod.rs": "mod sd;\npub use sd::Sd;\npub trait Density {}\n",
        "energy/sd.rs": "use super::Density;\npub struct Sd;\nimpl Density for Sd {}\n",
    })
    assert import_cycles.main([src]) == 1
    out = capsys.readouterr().out
    assert "energy/mod.rs" in out and "energy/sd.rs" in out and "1 import circle(s)" in out


def test_what_the_children_share_in_a_child_of_its_own_closes_no_circle(tmp_path, capsys):
    src = crate(tmp_path, {
        "lib.rs": "pub mod energy;\n",
        "energy/mod.rs": "mod density;\nmod sd;\npub use density::Density;\npub use sd::Sd;\n",
        "energy/density.rs": "pub trait Density {}\n",
        "energy/sd.rs": "use super::density::Density;\npub struct Sd;\nimpl Density for Sd {}\n",
    })
    assert import_cycles.main([src]) == 0
    assert "0 import circle(s)" in capsys.readouterr().out


def test_unit_tests_and_comments_are_not_arrows(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod a;\npub mod b;\n",
        "a.rs": "use crate::b::B;\npub struct A;\n",
        "b.rs": "// crate::a::A is named in a comment only\npub struct B;\n"
                "#[cfg(test)]\nmod tests {\n    use crate::a::A;\n}\n",
    })
    assert import_cycles.main([src]) == 0
