#!/usr/bin/env python3
"""Import circles between the files of a crate: the strongly connected components (more than
one file) of the graph "file A names a path into file B" (`crate::`, `super::`, `self::` paths
in `use` items and in code, and child modules named without a prefix; a brace group's items
each, `use super::{a::X, b}` naming `a` and `b`). A module naming its own submodules counts
too (`pub use summary::Row;` or `pub use summary::{Row, Status};` in `run_folder/mod.rs` is an
arrow from `mod.rs` to `summary.rs`): so a `mod.rs` that re-exports its children cannot also
hold what they use, which goes into a child of its own (`energy/density.rs` beside
`energy/sd.rs`). A path inside an inline `mod name { ... }` is read from that module: its
`super::` is the file holding the block (`mod stop_column { use super::FAILED_STOP; }` in
`summary.rs` names `summary.rs`, not its parent), its `self::` and unprefixed children are the
inline module's. A file declared with `#[path = "x_tests.rs"] mod tests;` is that module (its
`super::` is the declaring file). The `mod` items themselves are wiring, not arrows. Comments are left out, and
so is a file's `#[cfg(test)] mod name { ... }` (its unit tests, at its end): tests may drive a
module through the entry points above it.

    python3 scripts/import_cycles.py [CRATE_SRC ...]   (default: harness/src solvers/src)

Prints each circle's files and exits 1 when there is any.
"""
import os
import re
import sys

PATH = re.compile(r"\b(crate|super|self)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
CHILD = re.compile(r"(?<![:\w])([a-z_][a-z0-9_]*)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
# the head of a brace group: `crate::a::{`, `super::{`, `summary::{`, `std::{`
GROUP = re.compile(r"(?<![:\w])([A-Za-z_][A-Za-z0-9_]*)((?:::[A-Za-z_][A-Za-z0-9_]*)*)::\{")
INLINE = re.compile(r"\bmod\s+([A-Za-z_][A-Za-z0-9_]*)\s*\{")
# what strip_comments skips over: comments, strings, raw strings, char literals (not lifetimes)
LEXEME = re.compile(r"//|/\*|(?<!\w)b?r(#*)\"|\"|'(?:\\(?:u\{[0-9a-fA-F]+\}|x[0-9a-fA-F]{2}|.)|[^'\\\n])'")
STRING = re.compile(r'"(?:\\.|[^"\\])*"', re.S)


PATH_MOD = re.compile(r"#\[path\s*=\s*\"([^\"]+)\.rs\"\]\s*(?:#\[[^\]]*\]\s*)*(?:pub(?:\([a-z]+\))?\s+)?mod\s+(\w+)\s*;")


def modules(src):
    """Module path (tuple) -> file, for every .rs file under `src`; a file declared with
    `#[path = "x.rs"] mod name;` is the module `name` of the declaring file (the path taken
    beside that file, as rustc does for a `mod.rs` and, for these tests, a leaf file)."""
    out = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(root, f), src)
            parts = rel[:-3].split(os.sep)
            if parts[-1] in ("mod", "lib", "main"):
                parts = parts[:-1]
            out[tuple(parts)] = os.path.join(src, rel)
    for here, path in list(out.items()):
        for file, name in PATH_MOD.findall(open(path, encoding="utf-8").read()):
            target = os.path.normpath(os.path.join(os.path.dirname(path), file + ".rs"))
            for key in [k for k, p in out.items() if os.path.normpath(p) == target and k != here + (name,)]:
                del out[key]
            if os.path.exists(target):
                out[here + (name,)] = target
    return out


def strip_comments(text):
    """`text` without its comments and its unit tests (a `#[cfg(test)] mod name { ... }` and
    everything after it), the braces in its string and char literals blanked: a format
    string's `{}` opens no block, and a `//` in a string is no comment."""
    out, at = [], 0
    while True:
        m = LEXEME.search(text, at)
        if not m:
            out.append(text[at:])
            break
        out.append(text[at : m.start()])
        token = m.group()
        if token == "//":
            end = text.find("\n", m.start())
            end = len(text) if end < 0 else end
        elif token == "/*":
            depth, end = 1, m.end()
            while end < len(text) and depth:
                step = text[end : end + 2]
                depth += 1 if step == "/*" else -1 if step == "*/" else 0
                end += 2 if step in ("/*", "*/") else 1
            out.append(" ")
        else:
            if token == '"':
                string = STRING.match(text, m.start())
                end = string.end() if string else len(text)
            elif token.startswith("'"):
                end = m.end()
            else:  # a raw string: r"..", r#".."#
                close = text.find('"' + m.group(1), m.end())
                end = len(text) if close < 0 else close + 1 + len(m.group(1))
            out.append(text[m.start() : end].replace("{", " ").replace("}", " "))
        at = end
    text = "".join(out)
    tests = re.search(r"#\[cfg\(test\)\]\s*(pub(\([a-z]+\))?\s+)?mod\s+\w+\s*\{", text)
    return text[: tests.start()] if tests else text


def closing(text, at):
    """The index of the brace that closes the one at `at` (the text's end when none does)."""
    depth = 0
    for m in re.compile(r"[{}]").finditer(text, at):
        depth += 1 if m.group() == "{" else -1
        if depth == 0:
            return m.start()
    return len(text)


def inline_modules(text, here):
    """(start, end, module path) of each inline `mod name { ... }` in `text` (of the module
    `here`), nested ones with the path through their parents."""
    out = []
    for m in INLINE.finditer(text):
        end = closing(text, m.end() - 1)
        outer = [r for r in out if r[0] < m.start() < r[1]]
        parent = max(outer, key=lambda r: r[0])[2] if outer else here
        out.append((m.start(), end, parent + (m.group(1),)))
    return out


def group_items(body):
    """The paths (lists of segments) a brace group's `body` names: `a, b::{c, d as e}, self`
    gives [a], [b, c], [b, d], [] (`self`: the group's base itself)."""
    items, depth, start = [], 0, 0
    for i, c in enumerate(body + ","):
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        elif c == "," and depth == 0:
            items.append(body[start:i].strip())
            start = i + 1
    for item in items:
        head, brace, rest = item.partition("{")
        segs = [s.strip() for s in head.split(" as ")[0].split("::") if s.strip()]
        if brace:
            for inner in group_items(rest[: rest.rfind("}")]):
                yield segs + inner
        elif segs == ["self"]:
            yield []
        elif segs and segs[-1] != "*":
            yield segs
        elif segs:
            yield segs[:-1]


def named(text, here, mods):
    """Each path in `text` (of the module `here`) that names another module's file: the path
    as written, and that file. A path inside an inline `mod name { ... }` is read from that
    module: its `super::` is `here`, its `self::` and its children are the inline module's."""
    scopes = inline_modules(text, here)

    def scope(at):
        inside = [r for r in scopes if r[0] < at < r[1]]
        return max(inside, key=lambda r: r[0])[2] if inside else here

    paths = []  # (module the path is read in, root, the segments after it)
    groups = []
    for m in GROUP.finditer(text):
        if any(a < m.start() < b for a, b in groups):
            continue  # a group inside a group: its items are the outer group's
        end = closing(text, m.end() - 1)
        groups.append((m.start(), end))
        base = [s for s in m.group(2).split("::") if s]
        for item in group_items(text[m.end() : end]):
            paths.append((scope(m.start()), m.group(1), base + item))
    # the other paths, out of the groups (whose items were read above)
    for pattern in (PATH, CHILD):
        for m in pattern.finditer(text):
            if not any(a <= m.start() < b for a, b in groups):
                paths.append((scope(m.start()), m.group(1), m.group(2).split("::")[1:]))
    for at, root, segs in paths:
        written = "::".join([root] + segs)
        if root == "crate":
            start = ()
        elif root == "self":
            start = at
        elif root == "super":
            start = at[:-1]
            while segs and segs[0] == "super":
                start, segs = start[:-1], segs[1:]
        elif at + (root,) in mods:
            # a child module named without a prefix (`use summary::Row;` in `run_folder/mod.rs`)
            start, segs = at, [root] + segs
        else:
            continue
        # the longest prefix that is a module file
        for k in range(len(segs), -1, -1):
            key = start + tuple(segs[:k])
            if key in mods:
                if key != here:
                    yield written, mods[key]
                break


def targets(text, here, mods):
    """The files that the paths in `text` (of the module `here`) name."""
    return {f for _, f in named(text, here, mods)}


def sccs(graph):
    index, low, stack, on, out, n = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            out.append(comp)

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    return out


def main(srcs):
    circles = []
    for src in srcs:
        mods = modules(src)
        graph = {}
        for here, path in mods.items():
            text = strip_comments(open(path, encoding="utf-8").read())
            graph[path] = sorted(t for t in targets(text, here, mods) if t != path)
        circles += [sorted(c) for c in sccs(graph) if len(c) > 1]
    for c in circles:
        print(f"{len(c)} files: " + " ".join(c))
    print(f"{len(circles)} import circle(s)")
    return 1 if circles else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or ["harness/src", "solvers/src"]))
