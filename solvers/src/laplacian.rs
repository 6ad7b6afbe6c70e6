//! The stretch-weighted Laplacian `L_S(f)` of the AEM paper (Eq. 2c-2d) on a fixed sparsity
//! pattern, and its principal submatrices `L_II`, `L_BB` as lower-triangular CSC blocks for
//! [`SpdSolver`](crate::linear::SpdSolver) (symbolic analysis once, numeric refills after).
//!
//! The weight of edge `ij` in triangle `ijk` is `cot(theta_k(f)) |f(tau)| / (2 |tau|)`. With
//! `cot(theta_k) = <f_i - f_k, f_j - f_k> / (2 |f(tau)|)` this is `<f_i - f_k, f_j - f_k> /
//! (4 |tau|)`, which needs neither image angles nor a positive image area
//! (as the AEM authors' code computes it). For the identity map (3D
//! positions) it is the ordinary cotangent Laplacian with `cot / 2` weights.

use crate::grouping::grouped;
use crate::mesh::topology::is_proper;
use rayon::prelude::*;

/// Faces per parallel chunk (fixed: results do not depend on the thread count).
const CHUNK: usize = 2048;

/// Full symmetric `n x n` CSR pattern of a mesh's vertex graph with per-face value slots.
#[derive(Clone, Debug)]
pub struct LaplacianPattern {
    /// Number of vertices (rows and columns).
    pub n: usize,
    /// Start of each row in `col` (length `n + 1`).
    pub row_ptr: Vec<usize>,
    /// Column of each entry: the vertex itself and its neighbours, sorted within each row.
    pub col: Vec<usize>,
    /// Slot of the diagonal entry of each row.
    pub diag: Vec<usize>,
    /// Per face, the slots of `(i, j)` and `(j, i)` for the edge opposite local vertex `k`,
    /// `k = 0, 1, 2` (edge `(1, 2)`, `(2, 0)`, `(0, 1)`).
    face_slots: Vec<[[usize; 2]; 3]>,
}

impl LaplacianPattern {
    /// The pattern of the proper faces of `faces` over `n` vertices; every vertex has its diagonal.
    pub fn new(faces: &[[usize; 3]], n: usize) -> LaplacianPattern {
        // Every vertex's neighbours and itself, sorted; duplicates removed below.
        let (start, all) = grouped(n, || {
            let edges = faces.iter().filter(|f| is_proper(f, n)).flat_map(|f| {
                (0..3).flat_map(move |k| {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    [(a, b), (b, a)]
                })
            });
            (0..n).map(|v| (v, v)).chain(edges)
        });
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let mut col = Vec::with_capacity(all.len() / 2 + n);
        let mut diag = Vec::with_capacity(n);
        for v in 0..n {
            let row = col.len();
            col.extend_from_slice(&all[start[v]..start[v + 1]]);
            let mut k = row;
            for i in row + 1..col.len() {
                if col[i] != col[k] {
                    k += 1;
                    col[k] = col[i];
                }
            }
            col.truncate(k + 1);
            diag.push(row + col[row..].partition_point(|&c| c < v));
            row_ptr.push(col.len());
        }
        let slot = |a: usize, b: usize| -> usize {
            let row = &col[row_ptr[a]..row_ptr[a + 1]];
            // Every face edge is in the neighbour lists by construction.
            row_ptr[a] + row.binary_search(&b).unwrap_or(0)
        };
        let face_slots = faces
            .par_iter()
            .with_min_len(CHUNK)
            .map(|f| {
                std::array::from_fn(|k| {
                    let (i, j) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                    [slot(i, j), slot(j, i)]
                })
            })
            .collect();
        LaplacianPattern { n, row_ptr, col, diag, face_slots }
    }

    /// Number of stored entries: the length of the values array.
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Values of `L` for edge weights `w[t][k]` (edge opposite local vertex `k` of face `t`):
    /// off-diagonal `-sum w`, diagonal the negated row sum (Eq. 2c).
    pub fn assemble(&self, weights: &[[f64; 3]], values: &mut Vec<f64>) {
        values.clear();
        values.resize(self.nnz(), 0.0);
        for (slots, w) in self.face_slots.iter().zip(weights) {
            for k in 0..3 {
                let [ij, ji] = slots[k];
                values[ij] -= w[k];
                values[ji] -= w[k];
            }
        }
        for r in 0..self.n {
            let off: f64 =
                (self.row_ptr[r]..self.row_ptr[r + 1]).filter(|&s| s != self.diag[r]).map(|s| values[s]).sum();
            values[self.diag[r]] = -off;
        }
    }

    /// `y = L x` for one coordinate vector `x` of length `n`.
    pub fn mul(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|r| (self.row_ptr[r]..self.row_ptr[r + 1]).map(|s| values[s] * x[self.col[s]]).sum())
            .collect()
    }
}

/// Stretch weights `w[t][k] = <p_i - p_k, p_j - p_k> / (4 |tau_t|)` for the edge `ij` opposite
/// local vertex `k`, with `p` the image positions (`dim` = 2, interleaved) or the source
/// positions (`dim` = 3, the identity map).
pub fn stretch_weights(faces: &[[usize; 3]], source_area: &[f64], p: &[f64], dim: usize) -> Vec<[f64; 3]> {
    faces
        .par_iter()
        .with_min_len(CHUNK)
        .zip(source_area.par_iter())
        .map(|(f, &a)| {
            std::array::from_fn(|k| {
                let (i, j, m) = (f[(k + 1) % 3], f[(k + 2) % 3], f[k]);
                let dot: f64 =
                    (0..dim).map(|d| (p[dim * i + d] - p[dim * m + d]) * (p[dim * j + d] - p[dim * m + d])).sum();
                dot / (4.0 * a)
            })
        })
        .collect()
}

/// The principal submatrix of a [`LaplacianPattern`] on a vertex subset, as a lower CSC
/// block (sorted rows, diagonal first in each column) with the full-matrix slot of each entry.
#[derive(Clone, Debug)]
pub struct SubBlock {
    /// Number of vertices in the subset (rows and columns).
    pub n: usize,
    /// Start of each column in `row_idx` (length `n + 1`).
    pub col_ptr: Vec<usize>,
    /// Local row of each entry, `>=` its column.
    pub row_idx: Vec<usize>,
    /// Position in `row_idx` of each column's diagonal entry (its first).
    pub diag: Vec<usize>,
    src: Vec<usize>,
}

impl SubBlock {
    /// `vertices[c]` is the global vertex of local index `c`; `local[v]` its inverse
    /// (`usize::MAX` outside the subset).
    pub fn new(pat: &LaplacianPattern, vertices: &[usize], local: &[usize]) -> SubBlock {
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        let mut diag = Vec::with_capacity(vertices.len());
        let mut src = Vec::new();
        for (c, &v) in vertices.iter().enumerate() {
            let mut entries: Vec<(usize, usize)> = (pat.row_ptr[v]..pat.row_ptr[v + 1])
                .filter_map(|s| {
                    let l = local[pat.col[s]];
                    (l != usize::MAX && l >= c).then_some((l, s))
                })
                .collect();
            entries.sort_unstable();
            diag.push(row_idx.len());
            for (l, s) in entries {
                row_idx.push(l);
                src.push(s);
            }
            col_ptr.push(row_idx.len());
        }
        SubBlock { n: vertices.len(), col_ptr, row_idx, diag, src }
    }

    /// The block's values gathered from the full matrix values.
    pub fn gather(&self, full: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        self.gather_into(full, &mut out);
        out
    }

    /// [`SubBlock::gather`] into `out`'s storage (no allocation once it has the capacity).
    pub fn gather_into(&self, full: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.src.iter().map(|&s| full[s]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fan() -> (Vec<[usize; 3]>, Vec<f64>) {
        // A hexagon fan around vertex 0 in the plane.
        let mut p = vec![0.0, 0.0];
        for k in 0..6 {
            let a = std::f64::consts::PI / 3.0 * k as f64;
            p.extend([a.cos(), a.sin()]);
        }
        let faces = (0..6).map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
        (faces, p)
    }

    #[test]
    fn identity_weights_are_the_cotan_laplacian_and_rows_sum_to_zero() {
        let (faces, p) = fan();
        let area: Vec<f64> = faces.iter().map(|_| 3f64.sqrt() / 4.0).collect();
        let w = stretch_weights(&faces, &area, &p, 2);
        // equilateral: cot(60)/2 on every edge
        for wt in &w {
            for &x in wt {
                assert!((x - 0.5 / 3f64.sqrt()).abs() < 1e-14);
            }
        }
        let pat = LaplacianPattern::new(&faces, 7);
        let mut vals = Vec::new();
        pat.assemble(&w, &mut vals);
        let ones = vec![1.0; 7];
        assert!(pat.mul(&vals, &ones).iter().all(|v| v.abs() < 1e-14));
        // interior vertex: 6 edges of weight 2 * cot(60)/2
        assert!((vals[pat.diag[0]] - 6.0 / 3f64.sqrt()).abs() < 1e-13);
        // symmetric
        for r in 0..7 {
            for s in pat.row_ptr[r]..pat.row_ptr[r + 1] {
                let c = pat.col[s];
                let back = pat.row_ptr[c] + pat.col[pat.row_ptr[c]..pat.row_ptr[c + 1]].binary_search(&r).unwrap();
                assert_eq!(vals[s], vals[back]);
            }
        }
    }

    #[test]
    fn sub_block_is_the_principal_submatrix() {
        let (faces, p) = fan();
        let area = vec![0.3; 6];
        let w = stretch_weights(&faces, &area, &p, 2);
        let pat = LaplacianPattern::new(&faces, 7);
        let mut vals = Vec::new();
        pat.assemble(&w, &mut vals);
        let verts = vec![4, 1, 2];
        let mut local = vec![usize::MAX; 7];
        for (c, &v) in verts.iter().enumerate() {
            local[v] = c;
        }
        let b = SubBlock::new(&pat, &verts, &local);
        let bv = b.gather(&vals);
        let entry = |r: usize, c: usize| {
            pat.col[pat.row_ptr[r]..pat.row_ptr[r + 1]]
                .binary_search(&c)
                .map(|k| vals[pat.row_ptr[r] + k])
                .unwrap_or(0.0)
        };
        for c in 0..3 {
            assert_eq!(b.row_idx[b.diag[c]], c);
            for k in b.col_ptr[c]..b.col_ptr[c + 1] {
                assert_eq!(bv[k], entry(verts[b.row_idx[k]], verts[c]));
            }
        }
        // (1, 2) is an edge, (4, 1) is not: column of local 0 (vertex 4) holds only its diagonal
        assert_eq!(b.col_ptr[1] - b.col_ptr[0], 1);
        assert_eq!(b.col_ptr[2] - b.col_ptr[1], 2);
    }

    /// Each row is the vertex's sorted one-ring and itself (an unreferenced vertex: itself),
    /// the diagonal slot points at the vertex, and every face edge has its two slots.
    #[test]
    fn pattern_rows_are_the_one_rings_and_the_vertex() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let n = mesh.n_vertices() + 1;
        let pat = LaplacianPattern::new(&mesh.faces, n);
        let nbrs = crate::mesh::topology::vertex_neighbors(&mesh.faces, n);
        for (v, nb) in nbrs.iter().enumerate() {
            let mut want = nb.clone();
            want.push(v);
            want.sort_unstable();
            assert_eq!(&pat.col[pat.row_ptr[v]..pat.row_ptr[v + 1]], &want[..], "row {v}");
            assert_eq!(pat.col[pat.diag[v]], v);
        }
        assert_eq!(&pat.col[pat.row_ptr[n - 1]..], &[n - 1]);
        for (f, slots) in mesh.faces.iter().zip(&pat.face_slots) {
            for k in 0..3 {
                let (i, j) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                let [ij, ji] = slots[k];
                assert!(pat.row_ptr[i] <= ij && ij < pat.row_ptr[i + 1] && pat.col[ij] == j);
                assert!(pat.row_ptr[j] <= ji && ji < pat.row_ptr[j + 1] && pat.col[ji] == i);
            }
        }
    }
}
