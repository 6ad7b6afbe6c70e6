#!/usr/bin/env python3
"""Prepare meshes for mapbench: report, optionally repair, check, write clean OBJ, register.

    python scripts/prepare_datasets.py INPUT [INPUT ...] --out-dir DIR [--repair]
        [--datasets FILE] [--tasks param,authalic] [--tags mine,small] [--dry-run]

INPUT is a mesh file (OBJ, OFF, PLY, STL; read with trimesh) or a folder of them. For each
mesh the script prints a report (vertices, faces, duplicate and unreferenced vertices,
degenerate and duplicate faces, non-manifold edges, inconsistently oriented edges,
components, boundary loops, Euler characteristic). With --repair it merges duplicate
vertices, drops degenerate and duplicate faces, keeps the largest component and drops
unreferenced vertices. A mesh that is still not usable (non-manifold or inconsistently
oriented edges, or not a topological disk when a task needs one: param, authalic) is
refused with the reason; otherwise it is written to DIR/<name>.obj and, with --datasets,
appended to that registry as an entry with name, file (relative to DIR: run mapbench with
MAPBENCH_MESHES=DIR), sha256, vertices, faces, tasks and tags.

Exit status: 0 when every input was usable, 1 when at least one was refused, 2 on usage
errors (no input found, unreadable datasets file, name already registered).
"""

from __future__ import annotations

import argparse
import hashlib
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

MESH_SUFFIXES = {".obj", ".off", ".ply", ".stl"}
DISK_TASKS = {"param", "authalic"}
KNOWN_TASKS = {"param", "deform", "authalic"}


@dataclass
class Report:
    """What is wrong (or not) with a triangle mesh, by count."""

    vertices: int
    faces: int
    duplicate_vertices: int
    unreferenced_vertices: int
    degenerate_faces: int
    duplicate_faces: int
    nonmanifold_edges: int
    inconsistent_edges: int
    components: int
    boundary_loops: int
    euler: int
    notes: list[str] = field(default_factory=list)

    @property
    def is_disk(self) -> bool:
        return self.components == 1 and self.boundary_loops == 1 and self.euler == 1

    def lines(self) -> list[str]:
        return [
            f"vertices {self.vertices}, faces {self.faces}",
            f"duplicate vertices {self.duplicate_vertices}, unreferenced vertices {self.unreferenced_vertices}",
            f"degenerate faces {self.degenerate_faces}, duplicate faces {self.duplicate_faces}",
            f"non-manifold edges {self.nonmanifold_edges}, inconsistently oriented edges {self.inconsistent_edges}",
            f"components {self.components}, boundary loops {self.boundary_loops}, "
            f"Euler characteristic {self.euler}, disk: {'yes' if self.is_disk else 'no'}",
        ]


def face_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    if len(f) == 0:
        return np.zeros(0)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def degenerate_mask(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Faces with a repeated vertex or an area below 1e-14 of the squared bounding-box diagonal."""
    if len(f) == 0:
        return np.zeros(0, dtype=bool)
    repeated = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    diag2 = float(np.sum((v.max(axis=0) - v.min(axis=0)) ** 2)) if len(v) else 0.0
    return repeated | (face_areas(v, f) <= 1e-14 * max(diag2, 1e-300))


def duplicate_face_mask(f: np.ndarray) -> np.ndarray:
    """True for the second and later copies of a face with the same vertex set."""
    if len(f) == 0:
        return np.zeros(0, dtype=bool)
    _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    mask = np.ones(len(f), dtype=bool)
    mask[first] = False
    return mask


def components(n: int, f: np.ndarray) -> np.ndarray:
    """Component label of every face (faces sharing a vertex are connected); union-find."""
    parent = list(range(n))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b, c in f.tolist():
        for u, w in ((a, b), (b, c)):
            ru, rw = find(u), find(w)
            if ru != rw:
                parent[ru] = rw
    return np.array([find(a) for a in f[:, 0].tolist()], dtype=np.int64) if len(f) else np.zeros(0, np.int64)


def edge_stats(f: np.ndarray) -> tuple[int, int, int, int]:
    """(edges, non-manifold edges, inconsistently oriented edges, boundary loops)."""
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]) if len(f) else np.zeros((0, 2), np.int64)
    undirected = np.sort(directed, axis=1)
    keys, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    forward = np.zeros(len(keys), dtype=np.int64)
    np.add.at(forward, inverse, (directed[:, 0] < directed[:, 1]).astype(np.int64))
    nonmanifold = int(np.sum(counts > 2))
    inconsistent = int(np.sum((counts == 2) & (forward != 1)))
    # Boundary loops: components of the graph of boundary edges.
    boundary = keys[counts == 1]
    loops = 0
    if len(boundary):
        verts = np.unique(boundary)
        index = {int(x): i for i, x in enumerate(verts.tolist())}
        parent = list(range(len(verts)))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for a, b in boundary.tolist():
            ra, rb = find(index[a]), find(index[b])
            if ra != rb:
                parent[ra] = rb
        loops = len({find(i) for i in range(len(verts))})
    return len(keys), nonmanifold, inconsistent, loops


def report(v: np.ndarray, f: np.ndarray) -> Report:
    n = len(v)
    referenced = np.zeros(n, dtype=bool)
    if len(f):
        referenced[f.reshape(-1)] = True
    _, unique_index = np.unique(np.round(v, 12), axis=0, return_index=True) if n else (None, np.zeros(0))
    n_edges, nonmanifold, inconsistent, loops = edge_stats(f)
    used = int(referenced.sum())
    return Report(
        vertices=n,
        faces=len(f),
        duplicate_vertices=n - len(unique_index),
        unreferenced_vertices=n - used,
        degenerate_faces=int(degenerate_mask(v, f).sum()),
        duplicate_faces=int(duplicate_face_mask(f).sum()),
        nonmanifold_edges=nonmanifold,
        inconsistent_edges=inconsistent,
        components=len(set(components(n, f).tolist())),
        boundary_loops=loops,
        euler=used - n_edges + len(f),
    )


def repair(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Merge duplicate vertices, drop degenerate and duplicate faces, keep the largest
    component, drop unreferenced vertices. Returns the new arrays and what was done."""
    done = []
    if len(v):
        _, first, inverse = np.unique(np.round(v, 12), axis=0, return_index=True, return_inverse=True)
        inverse = inverse.reshape(-1)
        if len(first) < len(v):
            # Keep the first copy of each position, in the file's order.
            order = np.argsort(first)
            rank = np.empty_like(order)
            rank[order] = np.arange(len(order))
            done.append(f"merged {len(v) - len(first)} duplicate vertices")
            v, f = v[np.sort(first)], rank[inverse][f]
    bad = degenerate_mask(v, f)
    if bad.any():
        done.append(f"dropped {int(bad.sum())} degenerate faces")
        f = f[~bad]
    dup = duplicate_face_mask(f)
    if dup.any():
        done.append(f"dropped {int(dup.sum())} duplicate faces")
        f = f[~dup]
    labels = components(len(v), f)
    if len(set(labels.tolist())) > 1:
        values, counts = np.unique(labels, return_counts=True)
        keep = labels == values[np.argmax(counts)]
        done.append(f"kept the largest of {len(values)} components ({int(keep.sum())} of {len(f)} faces)")
        f = f[keep]
    referenced = np.zeros(len(v), dtype=bool)
    if len(f):
        referenced[f.reshape(-1)] = True
    if not referenced.all():
        new_index = np.cumsum(referenced) - 1
        done.append(f"dropped {int((~referenced).sum())} unreferenced vertices")
        v, f = v[referenced], new_index[f]
    return v, f, done


def problems(r: Report, tasks: list[str]) -> list[str]:
    """Why a mesh cannot be used as is (empty when usable)."""
    out = []
    if r.faces == 0:
        out.append("no faces")
    if r.duplicate_vertices:
        out.append(f"{r.duplicate_vertices} duplicate vertices (try --repair)")
    if r.unreferenced_vertices:
        out.append(f"{r.unreferenced_vertices} unreferenced vertices (try --repair)")
    if r.degenerate_faces:
        out.append(f"{r.degenerate_faces} degenerate faces (try --repair)")
    if r.duplicate_faces:
        out.append(f"{r.duplicate_faces} duplicate faces (try --repair)")
    if r.nonmanifold_edges:
        out.append(f"{r.nonmanifold_edges} non-manifold edges (cannot be repaired here)")
    if r.inconsistent_edges:
        out.append(f"{r.inconsistent_edges} inconsistently oriented edges (cannot be repaired here)")
    needs_disk = sorted(DISK_TASKS.intersection(tasks))
    if needs_disk and r.faces and not r.is_disk:
        out.append(
            f"not a topological disk ({r.components} components, {r.boundary_loops} boundary loops, "
            f"Euler characteristic {r.euler}), which tasks {', '.join(needs_disk)} need"
        )
    return out


def load_obj(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    """OBJ `v` and `f` lines (`v/vt/vn` and negative indices accepted), keeping every vertex in
    file order (trimesh drops unreferenced ones). Polygons are fan-triangulated; returns
    their number too."""
    verts, faces, polygons = [], [], 0
    for lineno, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = []
            for tok in parts[1:]:
                i = int(tok.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)
            if len(idx) < 3:
                raise ValueError(f"line {lineno}: a face with {len(idx)} vertices")
            if len(idx) > 3:
                polygons += 1
            faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    f = np.array(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) and (f.min() < 0 or f.max() >= len(verts)):
        raise ValueError("a face index is out of range")
    return np.array(verts, dtype=np.float64).reshape(-1, 3), f, polygons


def load(path: Path) -> tuple[np.ndarray, np.ndarray]:
    if path.suffix.lower() == ".obj":
        v, f, polygons = load_obj(path)
        if polygons:
            print(f"  note: fan-triangulated {polygons} polygons")
        return v, f
    mesh = trimesh.load(str(path), force="mesh", process=False)
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError("not a triangle mesh")
    v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    return v, f


def write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> bytes:
    lines = [f"# written by mapbench scripts/prepare_datasets.py: {len(v)} vertices, {len(f)} faces"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
    data = ("\n".join(lines) + "\n").encode()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    tmp.replace(path)
    return data


# Longest dataset name written; mapbench refuses run names <dataset>__<energy>__<solver> over
# 200 bytes (harness/src/plan/names.rs), and 64 leaves room for every energy and solver name.
MAX_NAME = 64


def dataset_name(path: Path) -> str:
    """A file-name safe registry name: lower-case ASCII letters and digits joined by single
    underscores (mapbench refuses separators, '..', control characters and '__', which
    separates dataset, energy and solver in run names)."""
    name = re.sub(r"[^a-z0-9]+", "_", path.stem.lower()).strip("_")
    return name[:MAX_NAME].rstrip("_") or "mesh"


def registered_names(datasets: Path) -> set[str]:
    if not datasets.exists():
        return set()
    import tomllib

    with datasets.open("rb") as fh:
        data = tomllib.load(fh)
    return {d.get("name", "") for d in data.get("dataset", [])}


def toml_list(items: list[str]) -> str:
    return "[" + ", ".join(f'"{x}"' for x in items) + "]"


def inputs(paths: list[Path]) -> list[Path]:
    out = []
    for p in paths:
        if p.is_dir():
            out += sorted(q for q in p.iterdir() if q.suffix.lower() in MESH_SUFFIXES)
        else:
            out.append(p)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("inputs", nargs="+", type=Path, help="mesh files (OBJ, OFF, PLY, STL) or folders")
    ap.add_argument("--out-dir", type=Path, required=True, help="where clean OBJ files are written")
    ap.add_argument("--datasets", type=Path, help="registry to append entries to (e.g. datasets.toml)")
    ap.add_argument("--repair", action="store_true", help="repair what can be repaired")
    ap.add_argument("--tasks", default="param,authalic", help="comma-separated tasks (default: param,authalic)")
    ap.add_argument("--tags", default="prepared", help="comma-separated tags (default: prepared)")
    ap.add_argument("--dry-run", action="store_true", help="report only; write nothing")
    args = ap.parse_args(argv)

    tasks = [t for t in args.tasks.split(",") if t]
    unknown = [t for t in tasks if t not in KNOWN_TASKS]
    if unknown:
        print(f"error: unknown task(s) {', '.join(unknown)} (known: {', '.join(sorted(KNOWN_TASKS))})", file=sys.stderr)
        return 2
    tags = [t for t in args.tags.split(",") if t]
    files = inputs(args.inputs)
    if not files:
        print("error: no mesh files found in the inputs", file=sys.stderr)
        return 2
    try:
        taken = registered_names(args.datasets) if args.datasets else set()
    except Exception as e:  # tomllib.TOMLDecodeError, OSError
        print(f"error: {args.datasets}: cannot read the datasets file: {e}", file=sys.stderr)
        return 2

    refused = 0
    entries = []
    for path in files:
        print(f"== {path}")
        try:
            v, f = load(path)
        except Exception as e:
            print(f"  refused: cannot read the mesh: {e}")
            refused += 1
            continue
        r = report(v, f)
        for line in r.lines():
            print(f"  {line}")
        if args.repair:
            v, f, done = repair(v, f)
            for d in done:
                print(f"  repair: {d}")
            if done:
                r = report(v, f)
                print(f"  after repair: {r.lines()[0]}; {r.lines()[-1]}")
        why = problems(r, tasks)
        if why:
            print(f"  refused: {'; '.join(why)}")
            refused += 1
            continue
        name = dataset_name(path)
        if name in taken:
            print(f"error: {path}: dataset name '{name}' is already in {args.datasets}", file=sys.stderr)
            return 2
        taken.add(name)
        if args.dry_run:
            print(f"  usable as '{name}' (dry run: nothing written)")
            continue
        out = args.out_dir / f"{name}.obj"
        data = write_obj(out, v, f)
        sha = hashlib.sha256(data).hexdigest()
        print(f"  wrote {out} ({r.vertices} vertices, {r.faces} faces, sha256 {sha[:12]}...)")
        entries.append(
            "\n[[dataset]]\n"
            f'name = "{name}"\n'
            f'file = "{name}.obj"\n'
            f"tasks = {toml_list(tasks)}\n"
            f"tags = {toml_list(tags)}\n"
            f'sha256 = "{sha}"\n'
            f"vertices = {r.vertices}\n"
            f"faces = {r.faces}\n"
        )
    if entries and args.datasets:
        with args.datasets.open("a") as fh:
            fh.write("".join(entries))
        print(f"appended {len(entries)} entries to {args.datasets} (run mapbench with MAPBENCH_MESHES={args.out_dir})")
    print(f"{len(files)} inputs: {len(files) - refused} usable, {refused} refused")
    return 1 if refused else 0


if __name__ == "__main__":
    sys.exit(main())
