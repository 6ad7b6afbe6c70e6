//! Combinatorial queries on triangle lists: one-rings, edges, boundary loops, components.
//!
//! Every function tolerates bad input (indices `>= n`, repeated vertices in a face,
//! non-manifold or inconsistently oriented faces) without panicking or looping forever:
//! such faces are skipped, so callers can run these before [`validate`](super::validate())
//! has rejected anything.

use crate::grouping::grouped;

/// True when `f` can take part in topology: all indices `< n` and pairwise distinct.
pub fn is_proper(f: &[usize; 3], n: usize) -> bool {
    f.iter().all(|&v| v < n) && f[0] != f[1] && f[1] != f[2] && f[0] != f[2]
}

/// Each proper face's three edges as `(a, b, forward)` with `a < b`, `forward` when the face
/// traverses the edge `a -> b`.
fn face_edges(faces: &[[usize; 3]], n: usize) -> impl Iterator<Item = (usize, usize, bool)> + '_ {
    faces.iter().filter(move |f| is_proper(f, n)).flat_map(|f| {
        (0..3).map(move |k| {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            if a < b {
                (a, b, true)
            } else {
                (b, a, false)
            }
        })
    })
}

/// Sorted, deduplicated one-ring neighbour list of every vertex (improper faces skipped).
pub fn vertex_neighbors(faces: &[[usize; 3]], n: usize) -> Vec<Vec<usize>> {
    let (start, all) = grouped(n, || face_edges(faces, n).flat_map(|(a, b, _)| [(a, b), (b, a)]));
    (0..n)
        .map(|v| {
            let mut l = all[start[v]..start[v + 1]].to_vec();
            l.dedup();
            l
        })
        .collect()
}

/// For each vertex, its corners `3 t + k` (vertex `k` of face `t`) in increasing face order
/// (indices `>= n` skipped). Summing per-corner contributions of a vertex in this order gives
/// the same bits as scattering them face after face, so a gradient can be summed per vertex in
/// parallel and still not depend on the thread count.
#[derive(Clone, Debug, Default)]
pub struct VertexCorners {
    ptr: Vec<usize>,
    corners: Vec<u32>,
}

impl VertexCorners {
    /// Face counts must fit `u32` (as the Newton pattern's scatter maps).
    pub fn new(faces: &[[usize; 3]], n: usize) -> VertexCorners {
        let mut ptr = vec![0usize; n + 1];
        for &v in faces.iter().flatten().filter(|&&v| v < n) {
            ptr[v + 1] += 1;
        }
        for v in 0..n {
            ptr[v + 1] += ptr[v];
        }
        let mut fill = ptr.clone();
        let mut corners = vec![0u32; ptr[n]];
        for (t, f) in faces.iter().enumerate() {
            for (k, &v) in f.iter().enumerate().filter(|(_, &v)| v < n) {
                corners[fill[v]] = (3 * t + k) as u32;
                fill[v] += 1;
            }
        }
        VertexCorners { ptr, corners }
    }

    /// The corners of vertex `v`, as `3 t + k`.
    #[inline]
    pub fn of(&self, v: usize) -> &[u32] {
        &self.corners[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// An undirected edge `a < b` with the faces incident to it, split by traversal direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// Smaller vertex index.
    pub a: usize,
    /// Larger vertex index.
    pub b: usize,
    /// Number of faces traversing the edge as `a -> b`.
    pub forward: usize,
    /// Number of faces traversing the edge as `b -> a`.
    pub backward: usize,
}

impl Edge {
    /// Number of incident faces.
    pub fn faces(&self) -> usize {
        self.forward + self.backward
    }

    /// An edge of a single face: it lies on the boundary.
    pub fn is_boundary(&self) -> bool {
        self.faces() == 1
    }

    /// Two faces traverse it in the same direction (their orientations disagree).
    pub fn is_inconsistent(&self) -> bool {
        self.forward > 1 || self.backward > 1
    }
}

/// Every undirected edge of the proper faces, sorted by `(a, b)`.
pub fn edges(faces: &[[usize; 3]], n: usize) -> Vec<Edge> {
    let (start, half) = grouped(n, || face_edges(faces, n).map(|(a, b, fwd)| (a, (b, fwd))));
    let mut out: Vec<Edge> = Vec::new();
    for a in 0..n {
        for &(b, fwd) in &half[start[a]..start[a + 1]] {
            match out.last_mut() {
                Some(e) if e.a == a && e.b == b => {
                    if fwd {
                        e.forward += 1
                    } else {
                        e.backward += 1
                    }
                }
                _ => out.push(Edge { a, b, forward: usize::from(fwd), backward: usize::from(!fwd) }),
            }
        }
    }
    out
}

/// The boundary loops, each as an ordered vertex list following the faces' orientation
/// (a boundary edge `a -> b` of a face is the step `a -> b`), so a counter-clockwise disk
/// has a counter-clockwise loop. A boundary edge is an edge with exactly one incident face.
///
/// Loops are listed by their smallest starting half-edge and start at their smallest vertex.
/// At a non-manifold vertex (several outgoing boundary edges) the walk takes the smallest
/// unused one and a loop closes on its first return to its start, so every boundary edge
/// is used exactly once; an open chain (inconsistent orientation) ends where it stops.
pub fn boundary_loops(faces: &[[usize; 3]], n: usize) -> Vec<Vec<usize>> {
    boundary_loops_of(&edges(faces, n), n)
}

/// [`boundary_loops`] from an edge list already computed by [`edges`].
pub fn boundary_loops_of(edges: &[Edge], n: usize) -> Vec<Vec<usize>> {
    let mut out_edges: Vec<(usize, usize)> = edges
        .iter()
        .filter(|e| e.is_boundary())
        .map(|e| if e.forward == 1 { (e.a, e.b) } else { (e.b, e.a) })
        .collect();
    out_edges.sort_unstable();
    // CSR over the source vertex, with a cursor skipping used half-edges.
    let mut start = vec![0usize; n + 1];
    for &(a, _) in &out_edges {
        start[a + 1] += 1;
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut cursor = start.clone();
    let mut used = vec![false; out_edges.len()];
    let next_unused = |v: usize, used: &[bool], cursor: &mut [usize]| -> Option<usize> {
        while cursor[v] < start[v + 1] {
            let i = cursor[v];
            cursor[v] += 1;
            if !used[i] {
                return Some(i);
            }
        }
        None
    };
    let mut loops = Vec::new();
    for first in 0..out_edges.len() {
        if used[first] {
            continue;
        }
        let origin = out_edges[first].0;
        let mut lp = vec![origin];
        let mut i = first;
        loop {
            used[i] = true;
            let b = out_edges[i].1;
            if b == origin {
                break;
            }
            lp.push(b);
            match next_unused(b, &used, &mut cursor) {
                Some(j) => i = j,
                None => break,
            }
        }
        loops.push(lp);
    }
    loops
}

/// Number of vertices referenced by at least one proper face.
pub fn referenced_vertices(faces: &[[usize; 3]], n: usize) -> usize {
    let mut seen = vec![false; n];
    for f in faces.iter().filter(|f| is_proper(f, n)) {
        for &v in f {
            seen[v] = true;
        }
    }
    seen.iter().filter(|&&s| s).count()
}

/// Number of connected components of the proper faces (faces sharing a vertex are connected).
pub fn components(faces: &[[usize; 3]], n: usize) -> usize {
    let mut uf = UnionFind::new(n);
    let mut seen = vec![false; n];
    for f in faces.iter().filter(|f| is_proper(f, n)) {
        uf.union(f[0], f[1]);
        uf.union(f[1], f[2]);
        seen[f[0]] = true;
    }
    let mut is_root = vec![false; n];
    for v in (0..n).filter(|&v| seen[v]) {
        is_root[uf.find(v)] = true;
    }
    is_root.iter().filter(|&&r| r).count()
}

/// Euler characteristic `V - E + F` of the proper faces, with `V` the referenced vertices
/// (an isolated vertex is a separate problem, not topology).
pub fn euler_characteristic(faces: &[[usize; 3]], n: usize) -> i64 {
    let f = faces.iter().filter(|f| is_proper(f, n)).count() as i64;
    referenced_vertices(faces, n) as i64 - edges(faces, n).len() as i64 + f
}

/// Number of fans (maximal edge-connected sets of incident faces) around every vertex;
/// a manifold vertex has at most one. Faces are joined across edges with exactly two faces.
pub fn fans_per_vertex(faces: &[[usize; 3]], n: usize) -> Vec<usize> {
    // Union-find over face corners: fans at v = corners at v - successful unions at v.
    let proper: Vec<usize> = (0..faces.len()).filter(|&f| is_proper(&faces[f], n)).collect();
    let mut fans = vec![0usize; n];
    for &v in proper.iter().flat_map(|&f| &faces[f]) {
        fans[v] += 1;
    }
    // The half-edges of each smaller vertex, as (larger vertex, proper face), sorted.
    let (start, half) = grouped(n, || {
        proper.iter().enumerate().flat_map(|(i, &f)| {
            let t = faces[f];
            (0..3).map(move |k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                (a.min(b), (a.max(b), i))
            })
        })
    });
    let corner = |i: usize, v: usize| -> usize {
        let t = faces[proper[i]];
        3 * i + t.iter().position(|&w| w == v).unwrap_or(0)
    };
    let mut uf = UnionFind::new(3 * proper.len());
    for a in 0..n {
        let group = &half[start[a]..start[a + 1]];
        let mut s = 0;
        while s < group.len() {
            let b = group[s].0;
            let e = s + group[s..].iter().take_while(|h| h.0 == b).count();
            if e - s == 2 {
                let (f, g) = (group[s].1, group[s + 1].1);
                for v in [a, b] {
                    if uf.union(corner(f, v), corner(g, v)) {
                        fans[v] -= 1;
                    }
                }
            }
            s = e;
        }
    }
    fans
}

/// Union-find with path halving and union by size.
pub(crate) struct UnionFind {
    parent: Vec<usize>,
    size: Vec<usize>,
}

impl UnionFind {
    pub(crate) fn new(n: usize) -> Self {
        UnionFind { parent: (0..n).collect(), size: vec![1; n] }
    }

    pub(crate) fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    /// Merge the sets of `a` and `b`; false when they were already one.
    pub(crate) fn union(&mut self, a: usize, b: usize) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra] < self.size[rb] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb] = ra;
        self.size[ra] += self.size[rb];
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit square split along 0-2, counter-clockwise.
    const SQUARE: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    /// Fan of `k` triangles around vertex 0 with rim 1..=k (open), counter-clockwise.
    fn fan(k: usize) -> Vec<[usize; 3]> {
        (1..=k).map(|i| [0, i, i + 1]).collect()
    }

    /// Ring of `m` quads between an inner loop 0..m and an outer loop m..2m, as triangles.
    fn annulus(m: usize) -> Vec<[usize; 3]> {
        let mut f = Vec::new();
        for i in 0..m {
            let j = (i + 1) % m;
            f.push([i, m + i, m + j]);
            f.push([i, m + j, j]);
        }
        f
    }

    #[test]
    fn vertex_corners_list_each_vertex_in_face_order() {
        let c = VertexCorners::new(&SQUARE, 5);
        assert_eq!(c.of(0), [0, 3]);
        assert_eq!(c.of(2), [2, 4]);
        assert_eq!((c.of(1), c.of(3)), (&[1u32][..], &[5u32][..]));
        assert!(c.of(4).is_empty(), "unreferenced");
        // an index out of range is skipped, not a panic
        let bad = VertexCorners::new(&[[0, 1, 7]], 3);
        assert_eq!((bad.of(0), bad.of(2)), (&[0u32][..], &[][..]));
    }

    #[test]
    fn square_topology() {
        assert_eq!(vertex_neighbors(&SQUARE, 4), vec![vec![1, 2, 3], vec![0, 2], vec![0, 1, 3], vec![0, 2]]);
        let e = edges(&SQUARE, 4);
        assert_eq!(e.len(), 5);
        assert_eq!(e.iter().filter(|e| e.is_boundary()).count(), 4);
        assert_eq!(e.iter().find(|e| (e.a, e.b) == (0, 2)).map(|e| (e.forward, e.backward)), Some((1, 1)));
        assert_eq!(boundary_loops(&SQUARE, 4), vec![vec![0, 1, 2, 3]]);
        assert_eq!(euler_characteristic(&SQUARE, 4), 1);
        assert_eq!(components(&SQUARE, 4), 1);
        assert_eq!(fans_per_vertex(&SQUARE, 4), vec![1; 4]);
    }

    #[test]
    fn fan_topology() {
        let f = fan(5);
        let n = 7;
        assert_eq!(vertex_neighbors(&f, n)[0], vec![1, 2, 3, 4, 5, 6]);
        assert_eq!(vertex_neighbors(&f, n)[3], vec![0, 2, 4]);
        assert_eq!(boundary_loops(&f, n), vec![vec![0, 1, 2, 3, 4, 5, 6]]);
        assert_eq!(euler_characteristic(&f, n), 1);
        // closing the fan makes vertex 0 interior
        let mut closed: Vec<[usize; 3]> = (1..=5).map(|i| [0, i, i % 5 + 1]).collect();
        assert_eq!(boundary_loops(&closed, 6), vec![vec![1, 2, 3, 4, 5]]);
        assert_eq!(fans_per_vertex(&closed, 6)[0], 1);
        closed.reverse();
        assert_eq!(boundary_loops(&closed, 6), vec![vec![1, 2, 3, 4, 5]]);
    }

    #[test]
    fn annulus_has_two_loops_and_euler_zero() {
        let f = annulus(6);
        let loops = boundary_loops(&f, 12);
        // inner loop runs clockwise (against the outer one), both following the faces
        assert_eq!(loops, vec![vec![0, 5, 4, 3, 2, 1], vec![6, 7, 8, 9, 10, 11]]);
        assert_eq!(euler_characteristic(&f, 12), 0);
        assert_eq!(components(&f, 12), 1);
        assert!(fans_per_vertex(&f, 12).iter().all(|&k| k == 1));
    }

    #[test]
    fn loop_of_a_ccw_disk_is_ccw() {
        // hexagon around a centre vertex 6, counter-clockwise, vertex numbering shuffled
        let ring = [3, 0, 5, 1, 4, 2];
        let pos: Vec<[f64; 2]> = (0..6)
            .map(|v| {
                let k = ring.iter().position(|&r| r == v).unwrap_or(0) as f64;
                let t = k * std::f64::consts::PI / 3.0;
                [t.cos(), t.sin()]
            })
            .chain([[0.0, 0.0]])
            .collect();
        let faces: Vec<[usize; 3]> = (0..6).map(|k| [6, ring[k], ring[(k + 1) % 6]]).collect();
        let loops = boundary_loops(&faces, 7);
        assert_eq!(loops.len(), 1);
        let l = &loops[0];
        assert_eq!(l[0], 0);
        let area: f64 = (0..l.len())
            .map(|k| {
                let (p, q) = (pos[l[k]], pos[l[(k + 1) % l.len()]]);
                p[0] * q[1] - p[1] * q[0]
            })
            .sum();
        assert!(area > 0.0, "loop {l:?} is clockwise");
    }

    #[test]
    fn components_count_separate_pieces() {
        let f = [[0, 1, 2], [3, 4, 5], [5, 4, 6]];
        assert_eq!(components(&f, 8), 2); // vertex 7 is unreferenced, not a component
        assert_eq!(referenced_vertices(&f, 8), 7);
        assert_eq!(boundary_loops(&f, 8).len(), 2);
    }

    #[test]
    fn bad_input_neither_panics_nor_hangs() {
        // bow-tie: two triangles sharing only vertex 0 -> two outgoing boundary edges at 0
        let bow = [[0, 1, 2], [0, 3, 4]];
        let loops = boundary_loops(&bow, 5);
        assert_eq!(loops, vec![vec![0, 1, 2], vec![0, 3, 4]]);
        assert_eq!(fans_per_vertex(&bow, 5)[0], 2);
        // figure-eight walk through the bow-tie vertex from elsewhere
        let bow2 = [[1, 2, 0], [0, 3, 4]];
        let total: usize = boundary_loops(&bow2, 5).iter().map(|l| l.len()).sum();
        assert_eq!(total, 6);
        // inconsistent orientation: open chains, no hang
        let flip = [[0, 1, 2], [0, 1, 3]];
        let total: usize = boundary_loops(&flip, 4).iter().map(|l| l.len()).sum();
        assert!(total >= 4);
        // three faces on one edge, out-of-range and repeated indices are skipped
        let nm = [[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 9, 1], [2, 2, 3]];
        assert_eq!(edges(&nm, 5).iter().find(|e| (e.a, e.b) == (0, 1)).map(|e| e.faces()), Some(3));
        let _ = boundary_loops(&nm, 5);
        let _ = fans_per_vertex(&nm, 5);
        assert_eq!(vertex_neighbors(&nm, 5)[0], vec![1, 2, 3, 4]);
        assert_eq!(components(&nm, 5), 1);
        assert!(boundary_loops(&[], 0).is_empty());
    }
    /// The edges of a messy triangle soup (repeats, both orientations, non-manifold edges,
    /// improper faces) against the half-edges sorted and counted directly.
    #[test]
    fn edges_of_a_soup_match_the_sorted_half_edges() {
        let n = 40;
        let faces: Vec<[usize; 3]> = (0..300).map(|i| [(i * 7) % n, (i * 11 + 3) % n, (i * 13 + 5) % 41]).collect();
        let mut half: Vec<(usize, usize, bool)> = face_edges(&faces, n).collect();
        half.sort_unstable();
        let mut want: Vec<Edge> = Vec::new();
        for (a, b, fwd) in half {
            match want.last_mut() {
                Some(e) if (e.a, e.b) == (a, b) => *(if fwd { &mut e.forward } else { &mut e.backward }) += 1,
                _ => want.push(Edge { a, b, forward: usize::from(fwd), backward: usize::from(!fwd) }),
            }
        }
        assert!(want.iter().any(|e| e.faces() > 2) && faces.iter().any(|f| !is_proper(f, n)));
        assert_eq!(edges(&faces, n), want);
    }
}
