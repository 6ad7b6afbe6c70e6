"""scripts/limits.py: the file and function limits and the comments' citations."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import limits  # noqa: E402


def test_a_function_is_measured_from_its_fn_line_to_its_closing_brace():
    lines = [
        "pub(crate) fn short(a: &str) -> usize {",
        '    let s = "}}}"; // a brace in a string or a comment is not one: {',
        "    let c = '{';",
        "    a.len()",
        "}",
        "trait T {",
        "    fn declared(&self);",
        "}",
        "impl X {",
        "    pub fn method(",
        "        &self,",
        "    ) -> Result<(), String> {",
        "        if true {",
        "            return Ok(());",
        "        }",
        "        Ok(())",
        "    }",
        "}",
    ]
    assert limits.function_lengths(lines) == [("short", 1, 5), ("method", 10, 8)]


def test_long_files_long_functions_and_outside_citations_are_offences(tmp_path):
    (tmp_path / "docs" / "src").mkdir(parents=True)
    (tmp_path / "docs" / "src" / "page.md").write_text("# page\n")
    body = "\n".join(["    x += 1;"] * 81)
    text = (
        "//! See docs/src/page.md and docs/src/missing.md.\n"
        "/// As design.md says; docs/src/design/numerics.md is a page of ours.\n"
        "// ../shared/notes/rust-stack.md section 2\n"
        f"fn long() {{\n{body}\n}}\n"
        "fn fine() {}\n"
    )
    found = limits.offences("harness/src/a.rs", text, str(tmp_path))
    whats = [(line, what) for _, line, what in found]
    assert (4, "fn long is 83 lines (limit 80)") in whats
    assert (1, "a comment cites docs/src/missing.md, which does not exist") in whats
    assert (2, "a comment cites a file outside the repository") in whats
    assert (3, "a comment cites a file outside the repository") in whats
    assert (2, "a comment cites docs/src/design/numerics.md, which does not exist") in whats
    assert len(found) == 5
    assert limits.offences("b.rs", "fn a() {}\n" * 651, str(tmp_path))[0][2] == "651 lines (limit 650)"
    assert limits.offences("b.rs", "fn a() {}\n" * 650, str(tmp_path)) == []


def test_two_types_of_one_name_are_offences():
    a = limits.type_names("a.rs", "pub struct Start {}\npub(crate) enum Kind {}\nstruct Private;\n")
    b = limits.type_names("b.rs", "/// doc\npub(super) struct Start<M> {\n    pub x: M,\n}\n")
    assert a == [("Start", "a.rs", 1), ("Kind", "a.rs", 2)]
    assert limits.shared_names(a + b) == [
        ("a.rs", 1, "type Start is declared again at b.rs:2"),
        ("b.rs", 2, "type Start is declared again at a.rs:1"),
    ]


def test_the_repository_keeps_its_limits():
    assert limits.main([]) == 0
