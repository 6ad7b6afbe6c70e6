#!/usr/bin/env python3
"""The house's limits, for the Rust sources of both crates (docs/src/design/layout.md):

- no file over 650 lines;
- no function over 80 lines (from its `fn` line to its closing brace; unit tests included);
- no comment cites a file outside the repository (`../shared/...`, a bare `design.md`), and
  every book page a comment cites (`docs/src/....md`) exists;
- no two types (`pub`, `pub(crate)`, `pub(super)` structs, enums, aliases, traits) of the two
  crates share a name: one name, one thing.

    python3 scripts/limits.py [SRC ...]   (default: harness/src solvers/src)

Prints each offence as `path:line: what` and exits 1 when there is any.
"""
import os
import re
import sys

MAX_FILE_LINES = 650
MAX_FN_LINES = 80

FN = re.compile(
    r"^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+)?(?:async\s+)?(?:unsafe\s+)?"
    r"(?:extern\s+\"[^\"]*\"\s+)?fn\s+(\w+)"
)
OUTSIDE = re.compile(r"\.\./shared|(?<![\w/])design\.md")
BOOK = re.compile(r"docs/src/[\w./-]+?\.md")
TYPE = re.compile(r"^\s*pub(?:\([^)]*\))?\s+(?:struct|enum|type|trait)\s+([A-Z]\w*)")
STRING = re.compile(r'"(?:\\.|[^"\\])*"')
CHAR = re.compile(r"'(?:\\.|[^'\\])'")


def code_of(line):
    """The line without its string and char literals and its `//` comment, for brace counts."""
    line = STRING.sub('""', line)
    line = CHAR.sub("''", line)
    return line.split("//", 1)[0]


def comment_of(line):
    """The line's `//` comment (doc comments included), or ''."""
    line = STRING.sub('""', line)
    at = line.find("//")
    return line[at:] if at >= 0 else ""


def function_lengths(lines):
    """(name, first line (1-based), length in lines) of every function with a body."""
    out = []
    for i, line in enumerate(lines):
        m = FN.match(line)
        if not m:
            continue
        depth, opened = 0, False
        for j in range(i, len(lines)):
            code = code_of(lines[j])
            if not opened and ";" in code and "{" not in code:
                break  # a declaration without a body (trait item, extern)
            for c in code:
                if c == "{":
                    depth += 1
                    opened = True
                elif c == "}":
                    depth -= 1
            if opened and depth == 0:
                out.append((m.group(1), i + 1, j - i + 1))
                break
    return out


def offences(path, text, root):
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    out = []
    if len(lines) > MAX_FILE_LINES:
        out.append((path, 1, f"{len(lines)} lines (limit {MAX_FILE_LINES})"))
    for name, first, length in function_lengths(lines):
        if length > MAX_FN_LINES:
            out.append((path, first, f"fn {name} is {length} lines (limit {MAX_FN_LINES})"))
    for n, line in enumerate(lines, 1):
        comment = comment_of(line)
        if not comment:
            continue
        if OUTSIDE.search(comment.replace("docs/src/design/", "")):
            out.append((path, n, "a comment cites a file outside the repository"))
        for page in BOOK.findall(comment):
            if not os.path.isfile(os.path.join(root, page)):
                out.append((path, n, f"a comment cites {page}, which does not exist"))
    return out


def type_names(path, text):
    """(name, path, line) of every public type `text` declares."""
    return [(m.group(1), path, n) for n, line in enumerate(text.split("\n"), 1) if (m := TYPE.match(line))]


def shared_names(declared):
    """An offence for each declaration of a type name declared more than once."""
    out = []
    for name, path, line in declared:
        others = [f"{p}:{n}" for m, p, n in declared if m == name and (p, n) != (path, line)]
        if others:
            out.append((path, line, f"type {name} is declared again at {', '.join(others)}"))
    return out


def main(argv):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    srcs = argv or [os.path.join(root, "harness", "src"), os.path.join(root, "solvers", "src")]
    found, declared = [], []
    for src in srcs:
        for base, _, files in sorted(os.walk(src)):
            for f in sorted(files):
                if f.endswith(".rs"):
                    path = os.path.join(base, f)
                    with open(path, encoding="utf-8") as fh:
                        text = fh.read()
                    rel = os.path.relpath(path, root)
                    found += offences(rel, text, root)
                    declared += type_names(rel, text)
    found += shared_names(declared)
    for path, line, what in found:
        print(f"{path}:{line}: {what}")
    print(f"{len(found)} offence(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
