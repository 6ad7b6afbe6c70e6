"""Tests of scripts/prepare_datasets.py on small generated meshes (run by .ci/run):

    python -m pytest scripts/tests
"""

import hashlib
import re
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import prepare_datasets as pd  # noqa: E402


def grid(n=6, z=0.0, offset=(0.0, 0.0)):
    """An n x n vertex grid of 2 (n-1)^2 consistently oriented triangles: a disk."""
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.stack([xs.ravel() + offset[0], ys.ravel() + offset[1], np.full(n * n, z)], axis=1)
    f = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j + 1, (i + 1) * n + j
            f += [[a, b, c], [a, c, d]]
    return v, np.array(f)


def write(path, v, f):
    trimesh.Trimesh(v, f, process=False).export(str(path))
    return path


def run(tmp_path, *args):
    out = tmp_path / "out"
    reg = tmp_path / "datasets.toml"
    code = pd.main([*map(str, args), "--out-dir", str(out), "--datasets", str(reg)])
    entries = tomllib.loads(reg.read_text())["dataset"] if reg.exists() else []
    return code, out, entries


def test_a_clean_disk_is_written_and_registered(tmp_path, capsys):
    v, f = grid()
    code, out, entries = run(tmp_path, write(tmp_path / "My Disk.obj", v, f), "--tags", "mine,small")
    assert code == 0
    assert len(entries) == 1
    e = entries[0]
    assert e["name"] == "my_disk" and e["file"] == "my_disk.obj"
    assert (e["vertices"], e["faces"]) == (36, 50)
    assert e["tasks"] == ["param", "authalic"] and e["tags"] == ["mine", "small"]
    data = (out / "my_disk.obj").read_bytes()
    assert hashlib.sha256(data).hexdigest() == e["sha256"]
    back = trimesh.load(str(out / "my_disk.obj"), force="mesh", process=False)
    assert np.array_equal(np.asarray(back.faces), f) and np.allclose(back.vertices, v)
    assert "disk: yes" in capsys.readouterr().out


def test_a_triangle_soup_is_refused_then_repaired_into_the_disk(tmp_path, capsys):
    v, f = grid(5)
    soup_v = v[f.reshape(-1)]
    soup_f = np.arange(len(soup_v)).reshape(-1, 3)
    path = write(tmp_path / "soup.ply", soup_v, soup_f)
    code, _, entries = run(tmp_path, path)
    text = capsys.readouterr().out
    assert code == 1 and entries == []
    assert "duplicate vertices (try --repair)" in text and "not a topological disk" in text
    code, _, entries = run(tmp_path, path, "--repair")
    assert code == 0
    assert (entries[0]["vertices"], entries[0]["faces"]) == (25, 32)
    assert "merged 71 duplicate vertices" in capsys.readouterr().out


def test_repair_drops_degenerate_duplicate_unreferenced_and_small_components(tmp_path, capsys):
    v, f = grid(6)
    v2, f2 = grid(3, offset=(5.0, 0.0))
    v = np.concatenate([v, v2, [[9.0, 9.0, 9.0]]])
    # the grid, a second small grid, a copy of the grid's face (0, 1, 7), a repeated-index face
    f = np.concatenate([f, f2 + 36, [[0, 1, 7]], [[2, 2, 3]]])
    path = tmp_path / "messy.obj"
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")
    code, _, entries = run(tmp_path, path, "--repair")
    text = capsys.readouterr().out
    assert code == 0, text
    assert "dropped 1 degenerate faces" in text
    assert "kept the largest of 2 components" in text
    assert "dropped 10 unreferenced vertices" in text
    assert (entries[0]["vertices"], entries[0]["faces"]) == (36, 50)


def test_closed_and_non_manifold_meshes_are_refused_with_the_reason(tmp_path, capsys):
    sphere = trimesh.creation.icosphere(subdivisions=1)
    write(tmp_path / "ball.off", np.asarray(sphere.vertices), np.asarray(sphere.faces))
    v, f = grid(3)
    fin = np.concatenate([v, [[0.5, 0.0, 1.0]]])
    write(tmp_path / "fin.stl", fin, np.concatenate([f, [[0, 4, 9]]]))  # interior edge (0,4) gets a third face
    code, _, entries = run(tmp_path, tmp_path)  # a folder: every mesh file in it
    text = capsys.readouterr().out
    assert code == 1 and entries == []
    assert "ball.off" in text and "0 boundary loops" in text and "tasks authalic, param need" in text
    assert "fin.stl" in text
    # STL stores a soup: after the merge the fin edge is non-manifold, which cannot be repaired
    code, _, entries = run(tmp_path, tmp_path / "fin.stl", "--repair")
    assert code == 1 and "1 non-manifold edges (cannot be repaired here)" in capsys.readouterr().out
    # a closed mesh is fine for a task that does not need a disk
    code, _, entries = run(tmp_path, tmp_path / "ball.off", "--tasks", "deform")
    assert code == 0 and entries[0]["tasks"] == ["deform"]


def test_usage_errors_exit_2(tmp_path):
    v, f = grid()
    path = write(tmp_path / "disk.obj", v, f)
    assert run(tmp_path, path)[0] == 0
    assert run(tmp_path, path)[0] == 2, "the name is already registered"
    assert run(tmp_path, tmp_path / "empty_dir_does_not_exist")[0] in (1, 2)
    (tmp_path / "empty").mkdir()
    assert run(tmp_path, tmp_path / "empty")[0] == 2
    assert pd.main([str(path), "--out-dir", str(tmp_path), "--tasks", "parm"]) == 2


def test_dry_run_writes_nothing(tmp_path):
    v, f = grid()
    path = write(tmp_path / "disk.obj", v, f)
    code, out, entries = run(tmp_path, path, "--dry-run")
    assert code == 0 and entries == [] and not out.exists()


@pytest.mark.parametrize("suffix", [".obj", ".off", ".ply", ".stl"])
def test_every_format_reads(tmp_path, suffix):
    v, f = grid(4)
    code, _, entries = run(tmp_path, write(tmp_path / f"m{suffix}", v, f), "--repair")
    assert code == 0 and (entries[0]["vertices"], entries[0]["faces"]) == (16, 18)


def test_obj_polygons_are_fan_triangulated_and_bad_indices_refused(tmp_path, capsys):
    (tmp_path / "quads.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 2/1 5/2 6/3 3/4\n")
    code, _, entries = run(tmp_path, tmp_path / "quads.obj")
    assert code == 0 and (entries[0]["vertices"], entries[0]["faces"]) == (6, 4)
    assert "fan-triangulated 2 polygons" in capsys.readouterr().out
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    code, _, _ = run(tmp_path, tmp_path / "bad.obj")
    assert code == 1 and "cannot read the mesh: a face index is out of range" in capsys.readouterr().out


@pytest.mark.parametrize(
    "stem",
    ["../../ESCAPED", "a__b", "tab\there", "new\nline", ".hidden", "Ünïcödé mesh", "x" * 300, "__", "C:x*?|"],
)
def test_registry_names_are_file_name_safe(stem):
    name = pd.dataset_name(Path(stem + ".obj"))
    assert re.fullmatch(r"[a-z0-9]+(_[a-z0-9]+)*", name), name
    assert len(name) <= pd.MAX_NAME
