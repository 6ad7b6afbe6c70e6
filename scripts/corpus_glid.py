#!/usr/bin/env python3
"""Triangulate the 2D shape cages shipped as data.mat in renjiec/GLID: the `glid` recipe of
`mapbench corpus fetch` (corpus.toml), the shared corpus's tools/gen_glid.py with its OBJ
writer inlined, so that it makes the same bytes.

The GLID data files hold only the polygonal cage (outer boundary + holes) and
point-to-point (P2P) constraint sets; GLID builds its mesh at run time with
Shewchuk's Triangle ('-q30 -a<area/10000>', Steiner points allowed on the
boundary).  We reproduce that recipe with the `triangle` PyPI binding and
write an OBJ (z = 0) plus a JSON sidecar with the P2P constraint sets, each
source point snapped to its nearest mesh vertex (as GLID does).
"""
import json
import sys

import numpy as np
import scipy.io as sio
import triangle



def write_obj(path, V, F, header_lines=()):
    """Plain OBJ: floats as Python's repr (they read back exactly), 1-based faces."""
    with open(path, "w") as fh:
        for h in header_lines:
            fh.write("# %s\n" % h)
        for x in V:
            fh.write("v %s %s %s\n" % (repr(float(x[0])), repr(float(x[1])), repr(float(x[2]))))
        for f in F + 1:
            fh.write("f %d %d %d\n" % (f[0], f[1], f[2]))


def cross2(u, w):
    return u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]


def signed_area(P):
    x, y = P[:, 0], P[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def interior_point(P):
    n = len(P)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], 1)
    t = triangle.triangulate({"vertices": P, "segments": seg}, "p")
    T, X = t["triangles"], t["vertices"]
    a = np.abs(cross2(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]]))
    k = int(np.argmax(a))
    return X[T[k]].mean(0)


def c2r(z):
    z = np.asarray(z)
    while z.dtype == object:
        z = np.asarray(z.ravel()[0])
    z = z.ravel()
    return np.stack([z.real, z.imag], 1)


def main(matfile, out_obj, out_json, ntri=10000):
    d = sio.loadmat(matfile)
    cages = [c2r(d["allcages"][i, 0]) for i in range(d["allcages"].shape[0])]
    outer, holes = cages[0], cages[1:]
    verts, segs, off = [], [], 0
    for P in cages:
        n = len(P)
        verts.append(P)
        segs.append(np.stack([np.arange(n), (np.arange(n) + 1) % n], 1) + off)
        off += n
    pslg = {"vertices": np.concatenate(verts), "segments": np.concatenate(segs)}
    if holes:
        pslg["holes"] = np.array([interior_point(h) for h in holes])
    net = abs(signed_area(outer)) - sum(abs(signed_area(h)) for h in holes)
    amax = net / ntri
    t = triangle.triangulate(pslg, "pq30a%.15f" % amax)
    X, T = t["vertices"], t["triangles"].astype(np.int64)
    # drop isolated vertices (GLID does the same)
    used = np.zeros(len(X), bool)
    used[T.ravel()] = True
    remap = -np.ones(len(X), np.int64)
    remap[used] = np.arange(used.sum())
    X, T = X[used], remap[T]
    # CCW orientation
    a = cross2(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])
    if (a < 0).sum() > (a > 0).sum():
        T = T[:, [0, 2, 1]]
    V = np.concatenate([X, np.zeros((len(X), 1))], 1)

    def snap(P):
        P = c2r(P)
        dd = ((P[:, None, :] - X[None, :, :]) ** 2).sum(-1)
        idx = dd.argmin(1)
        return idx.tolist(), np.sqrt(dd[np.arange(len(P)), idx]).tolist()

    sets = []
    if "P2Psrc" in d and d["P2Psrc"].size:
        i, dist = snap(d["P2Psrc"])
        sets.append({"name": "default (P2Psrc/P2Pdst)", "src": c2r(d["P2Psrc"]).tolist(),
                     "dst": c2r(d["P2Pdst"]).tolist(), "src_vertex": i, "snap_distance": dist})
    if "P2Psets" in d:
        for k, s in enumerate(d["P2Psets"].ravel()):
            src, dst = s["src"], s["dst"]
            i, dist = snap(src)
            sets.append({"name": "P2Psets[%d]" % k, "src": c2r(src).tolist(), "dst": c2r(dst).tolist(),
                         "src_vertex": i, "snap_distance": dist})
    info = {
        "source": "github.com/renjiec/GLID data/%s/data.mat (commit d2534c14b0dc487a494d6855c93e4658054d1e4f)" % matfile.split("glid_")[-1][:-4],
        "recipe": "triangle.triangulate(PSLG of allcages, 'pq30a%.6g') (area = net polygon area / %d); isolated vertices removed; faces CCW; z = 0" % (amax, ntri),
        "outer_cage_vertices": len(outer),
        "holes": len(holes),
        "vertex_index_base": 0,
        "p2p_sets": sets,
        "note": "src_vertex = nearest mesh vertex to each P2P source point (0-based, as in GLID's nearestNeighbor snapping); dst are target positions in the same 2D frame.",
    }
    write_obj(out_obj, V, T, ["2D shape triangulated from the cage polygon of github.com/renjiec/GLID data/%s/data.mat; see MANIFEST.toml" % matfile.split("glid_")[-1][:-4]])
    with open(out_json, "w") as fh:
        head = {k: v for k, v in info.items() if k != "p2p_sets"}
        body = json.dumps(head, indent=1)[:-2]
        sets_txt = ",\n".join("  " + json.dumps(s) for s in sets)
        fh.write(body + ',\n "p2p_sets": [\n' + sets_txt + "\n ]\n}\n")
    json.load(open(out_json))  # validate
    print(out_obj, len(V), len(T))


if __name__ == "__main__":
    # usage: corpus_glid.py glid_<Dir>.mat OUT.obj OUT.p2p.json
    main(sys.argv[1], sys.argv[2], sys.argv[3])
