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


def test_a_child_named_with_a_brace_group_is_an_arrow(tmp_path, capsys):
    src = crate(tmp_path, {
        "lib.rs": "pub mod run_folder;\n",
        "run_folder/mod.rs": "pub mod summary;\npub use summary::{Row, Status};\npub const FAILED: &str = \"error\";\n",
        "run_folder/summary.rs": "use super::FAILED;\npub struct Row;\npub enum Status {}\n",
    })
    assert import_cycles.main([src]) == 1
    out = capsys.readouterr().out
    assert "run_folder/mod.rs" in out and "run_folder/summary.rs" in out and "1 import circle(s)" in out


def test_nested_brace_groups_name_each_item(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod a;\npub mod b;\n",
        "a/mod.rs": "pub mod x;\npub mod y;\nuse self::{x::{X, X2}, y::Y as Z};\n",
        "a/x.rs": "pub struct X;\npub struct X2;\n",
        "a/y.rs": "pub struct Y;\n",
        "b.rs": "use crate::{a::{self, x}, b as _};\n",
    })
    mods = import_cycles.modules(src)
    targets = lambda rel, here: import_cycles.targets(  # noqa: E731
        import_cycles.strip_comments(open(os.path.join(src, rel)).read()), here, mods)
    assert targets("a/mod.rs", ("a",)) == {os.path.join(src, "a/x.rs"), os.path.join(src, "a/y.rs")}
    assert targets("b.rs", ("b",)) == {os.path.join(src, "a/mod.rs"), os.path.join(src, "a/x.rs")}


def test_super_in_an_inline_module_is_the_file_holding_it(tmp_path, capsys):
    src = crate(tmp_path, {
        "lib.rs": "pub mod run_folder;\n",
        "run_folder/mod.rs": "pub mod summary;\npub use summary::Row;\npub const FAILED: &str = \"error\";\n",
        "run_folder/summary.rs": "pub const FAILED_STOP: &str = \"error\";\n"
                                 "mod stop_column {\n    use super::FAILED_STOP;\n    use self::inner::F;\n"
                                 "    mod inner {\n        pub use super::super::FAILED_STOP as F;\n    }\n}\n"
                                 "pub struct Row;\n",
    })
    assert import_cycles.main([src]) == 0
    assert "0 import circle(s)" in capsys.readouterr().out


def test_after_an_inline_module_super_is_the_parent_again(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod run_folder;\n",
        "run_folder/mod.rs": "pub mod summary;\npub use summary::Row;\npub const FAILED: &str = \"error\";\n",
        "run_folder/summary.rs": "mod stop_column {\n    fn f() -> &'static str { \"{\" }\n}\n"
                                 "use super::FAILED;\npub struct Row;\n",
    })
    assert import_cycles.main([src]) == 1


def test_a_segment_that_starts_with_super_is_no_super(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod linear;\n",
        "linear/mod.rs": "mod analysis;\nmod supernodal;\n",
        "linear/analysis.rs": "use super::supernodal::{Schedule};\n",
        "linear/supernodal.rs": "pub struct Schedule;\n",
    })
    mods = import_cycles.modules(src)
    text = open(os.path.join(src, "linear/analysis.rs")).read()
    assert import_cycles.targets(text, ("linear", "analysis"), mods) == {os.path.join(src, "linear/supernodal.rs")}


def test_a_string_holds_no_comment_and_no_block(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod a;\npub mod b;\n",
        "a.rs": "const URL: &str = \"https://x/{\"; use crate::b::B;\npub struct A;\n",
        "b.rs": "mod inner { const C: char = '}'; }\nuse crate::a::A;\npub struct B;\n",
    })
    assert import_cycles.main([src]) == 1


def test_a_file_declared_with_path_is_the_module_it_declares(tmp_path):
    src = crate(tmp_path, {
        "lib.rs": "pub mod mesh;\n",
        "mesh/mod.rs": "pub mod validate;\npub use validate::check;\n",
        "mesh/validate.rs": "pub fn check() {}\n#[cfg(test)]\n#[path = \"validate_tests.rs\"]\nmod tests;\n",
        "mesh/validate_tests.rs": "use super::check;\n",
    })
    mods = import_cycles.modules(src)
    tests = os.path.join(src, "mesh/validate_tests.rs")
    assert mods[("mesh", "validate", "tests")] == tests
    assert ("mesh", "validate_tests") not in mods
    text = import_cycles.strip_comments(open(tests).read())
    assert import_cycles.targets(text, ("mesh", "validate", "tests"), mods) == {os.path.join(src, "mesh/validate.rs")}
