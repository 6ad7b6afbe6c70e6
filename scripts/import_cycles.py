#!/usr/bin/env python3
"""Import circles between the files of a crate: the strongly connected components (more than
one file) of the graph "file A names a path into file B" (`crate::`, `super::`, `self::` paths
in `use` items and in code, and child modules named without a prefix). A module naming its
own submodules counts too (`pub use summary::Row;` in `run_folder/mod.rs` is an arrow from
`mod.rs` to `summary.rs`): so a `mod.rs` that re-exports its children cannot also hold what
they use, which goes into a child of its own (`energy/density.rs` beside `energy/sd.rs`).
The `mod` items themselves are wiring, not arrows. A file's `#[cfg(test)] mod` (its unit
tests, at its end) is left out: tests may drive a module through the entry points above it.

    python3 scripts/import_cycles.py [CRATE_SRC ...]   (default: harness/src solvers/src)

Prints each circle's files and exits 1 when there is any.
"""
import os
import re
import sys

PATH = re.compile(r"\b(crate|super|self)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
CHILD = re.compile(r"(?<![:\w])([a-z_][a-z0-9_]*)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
GROUP = re.compile(r"\b(crate|super|self)((?:::[A-Za-z_][A-Za-z0-9_]*)*)::\{([^;]*?)\}", re.S)


def modules(src):
    """Module path (tuple) -> file, for every .rs file under `src`."""
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
    return out


def strip_comments(text):
    tests = re.search(r"#\[cfg\(test\)\]\s*(pub(\([a-z]+\))?\s+)?mod\s+\w+\s*\{", text)
    if tests:
        text = text[: tests.start()]
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def named(text, here, mods):
    """Each path in `text` (of the module `here`) that names another module's file: the path
    as written, and that file."""
    paths = []
    for m in GROUP.finditer(text):
        base = m.group(1), m.group(2)
        for item in re.split(r",", re.sub(r"\{[^{}]*\}", "", m.group(3))):
            name = item.strip().split(" as ")[0].split("::")[0].strip()
            if name and name != "self":
                paths.append((base[0], base[1] + "::" + name))
            elif name == "self":
                paths.append(base)
    paths += [(m.group(1), m.group(2)) for m in PATH.finditer(text)]
    # a child module named without a prefix (`use summary::Row;` in `run_folder/mod.rs`)
    for m in CHILD.finditer(text):
        if here + (m.group(1),) in mods:
            paths.append(("self", "::" + m.group(1) + m.group(2)))
    for root, rest in paths:
        written = root + rest
        if root == "crate":
            start = ()
        elif root == "self":
            start = here
        else:
            start = here
            for _ in range(rest.count("super") + 1):
                start = start[:-1]
            rest = rest.replace("::super", "")
        segs = [s for s in rest.split("::") if s and s != "super"]
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
