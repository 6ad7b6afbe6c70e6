//! Sparse assembly of per-element 6x6 blocks (faces) and, optionally, 8x8 blocks (pairs of
//! faces sharing an edge: the smoothness term) into the lower triangle of a symmetric
//! `2n x 2n` matrix in compressed-column form.
//!
//! The pattern and a scatter map (for every element, the value slot of each of its 21
//! lower-triangular local entries) are built once per mesh; each iteration only refills
//! values, so the symbolic factorization can be reused. The refill runs in parallel over
//! fixed chunks of value slots: each chunk walks, in element order, the elements with a slot
//! in it and adds their entries there. Every slot thus sums its contributions in element
//! order, as one sequential scatter would: the same bits for any thread count. Each block is
//! read about once, in order (a gather by slot read each block once per vertex, three times,
//! in scattered order, and took twice the time of the projection at 55k vertices).

use crate::linear::LowerPattern;
use crate::smoothness::Matrix8;
use nalgebra::Matrix6;
use rayon::prelude::*;

/// Value slots per parallel task: enough work to amortize rayon's scheduling and the
/// elements that straddle two chunks (read by both), few enough chunks to balance two threads.
const SLOTS_PER_TASK: usize = 262144;

/// Lower-triangular CSC pattern of the element-coupling graph with interleaved dofs.
#[derive(Clone, Debug)]
pub struct Pattern {
    /// Matrix dimension: twice the number of vertices.
    pub n: usize,
    /// Start of each column in `row_idx` (length `n + 1`).
    pub col_ptr: Vec<usize>,
    /// Row of each stored entry, sorted within each column (rows `>=` the column).
    pub row_idx: Vec<usize>,
    /// Value slot of each diagonal entry.
    pub diag: Vec<usize>,
    /// Per element, the slots of local entries `(a, b)` with `a >= b` in the order of
    /// [`LOWER`].
    pub scatter: Vec<[u32; 21]>,
    /// Per edge block (4 vertices), the slots of its entries in the order of [`LOWER8`].
    pub edge_scatter: Vec<[u32; 36]>,
    /// Value slots per chunk of the assembly ([`SLOTS_PER_TASK`]).
    chunk: usize,
    /// For each chunk of value slots, the elements with a slot in it, in increasing order:
    /// faces as their index, edge blocks as `faces + edge`.
    chunk_ptr: Vec<usize>,
    chunk_elements: Vec<u32>,
}

impl LowerPattern for Pattern {
    fn dim(&self) -> usize {
        self.n
    }

    fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    fn row_indices(&self) -> &[usize] {
        &self.row_idx
    }

    fn diagonal_slots(&self) -> &[usize] {
        &self.diag
    }
}

/// The lower-triangular entries `(a, b)`, `a >= b`, of an `N x N` block, row-major
/// (`M = N (N + 1) / 2`).
const fn lower_entries<const N: usize, const M: usize>() -> [(usize, usize); M] {
    let mut out = [(0, 0); M];
    let mut k = 0;
    let mut a = 0;
    while a < N {
        let mut b = 0;
        while b <= a {
            out[k] = (a, b);
            k += 1;
            b += 1;
        }
        a += 1;
    }
    out
}

/// Local lower-triangular entries of a 6x6 face block.
pub const LOWER: [(usize, usize); 21] = lower_entries::<6, 21>();

/// Local lower-triangular entries of an 8x8 edge block.
pub const LOWER8: [(usize, usize); 36] = lower_entries::<8, 36>();

/// A symmetric 6x6 element block as its 21 lower-triangular entries in [`LOWER`] order: what
/// the assembly reads, in 168 bytes instead of a full matrix's 288 (the Newton driver keeps
/// one per face, 336 MB at a million vertices, and streams them every iteration).
pub type Lower6 = [f64; 21];

/// The lower triangle of `m` in [`LOWER`] order.
#[inline]
pub fn pack_lower(m: &Matrix6<f64>) -> Lower6 {
    std::array::from_fn(|k| m[LOWER[k]])
}

/// A 6x6 block the assembly can read: entry `k` of [`LOWER`].
pub trait FaceBlock: Sync {
    /// The block's entry `LOWER[k]`.
    fn lower(&self, k: usize) -> f64;
}

impl FaceBlock for Matrix6<f64> {
    #[inline]
    fn lower(&self, k: usize) -> f64 {
        self[LOWER[k]]
    }
}

impl FaceBlock for Lower6 {
    #[inline]
    fn lower(&self, k: usize) -> f64 {
        self[k]
    }
}

#[inline]
fn local_dofs(f: &[usize; 3]) -> [usize; 6] {
    [2 * f[0], 2 * f[0] + 1, 2 * f[1], 2 * f[1] + 1, 2 * f[2], 2 * f[2] + 1]
}

#[inline]
fn edge_dofs(e: &[usize; 4]) -> [usize; 8] {
    std::array::from_fn(|i| 2 * e[i / 2] + i % 2)
}

impl Pattern {
    /// Build the pattern for `faces` over `n_vertices` vertices (every vertex gets its
    /// diagonal entries even if unreferenced, so the matrix is never structurally singular).
    pub fn new(faces: &[[usize; 3]], n_vertices: usize) -> Pattern {
        Self::with_edges(faces, &[], n_vertices)
    }

    /// The pattern of face blocks plus 8x8 blocks over the 4 vertices of each `edges` entry.
    pub fn with_edges(faces: &[[usize; 3]], edges: &[[usize; 4]], n_vertices: usize) -> Pattern {
        Self::chunked(faces, edges, n_vertices, SLOTS_PER_TASK)
    }

    /// [`Pattern::with_edges`] assembling in chunks of `chunk` value slots (tests use small
    /// chunks to have many on small meshes).
    fn chunked(faces: &[[usize; 3]], edges: &[[usize; 4]], n_vertices: usize, chunk: usize) -> Pattern {
        let n = 2 * n_vertices;
        let (col_ptr, row_idx) = lower_pattern(faces, edges, n);
        let slot = |r: usize, c: usize| -> usize {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            // the pattern was built from these very entries, so the search cannot miss
            col_ptr[c] + rows.binary_search(&r).unwrap_or_else(|_| unreachable!("entry ({r},{c}) not in pattern"))
        };
        let diag = (0..n).map(|c| slot(c, c)).collect();
        let scatter = faces
            .iter()
            .map(|f| {
                let d = local_dofs(f);
                let mut s = [0u32; 21];
                for (k, &(a, b)) in LOWER.iter().enumerate() {
                    let (r, c) = if d[a] >= d[b] { (d[a], d[b]) } else { (d[b], d[a]) };
                    s[k] = slot(r, c) as u32;
                }
                s
            })
            .collect::<Vec<[u32; 21]>>();
        let edge_scatter = edges
            .iter()
            .map(|e| {
                let d = edge_dofs(e);
                let mut s = [0u32; 36];
                for (k, &(a, b)) in LOWER8.iter().enumerate() {
                    let (r, c) = if d[a] >= d[b] { (d[a], d[b]) } else { (d[b], d[a]) };
                    s[k] = slot(r, c) as u32;
                }
                s
            })
            .collect::<Vec<[u32; 36]>>();
        // Each chunk's elements in element order, grouped by chunk (`crate::grouping`); an
        // element is listed once per chunk it writes to.
        let n_chunks = row_idx.len().div_ceil(chunk).max(1);
        let chunks_of = |slots: &[u32]| {
            let mut cs: Vec<usize> = slots.iter().map(|&p| p as usize / chunk).collect();
            cs.sort_unstable();
            cs.dedup();
            cs
        };
        let element_chunks: Vec<Vec<usize>> =
            scatter.iter().map(|s| chunks_of(s)).chain(edge_scatter.iter().map(|s| chunks_of(s))).collect();
        let pairs = || element_chunks.iter().enumerate().flat_map(|(e, cs)| cs.iter().map(move |&c| (c, e as u32)));
        let (chunk_ptr, chunk_elements) = crate::grouping::grouped(n_chunks, pairs);
        Pattern { n, col_ptr, row_idx, diag, scatter, edge_scatter, chunk, chunk_ptr, chunk_elements }
    }

    /// Number of stored (lower-triangle) entries: the length of the values array.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Overwrite `values` with the sum of the element blocks, in parallel over chunks of value
    /// slots; each slot sums its contributions in element order, so the result does not depend
    /// on the thread count.
    pub fn assemble<B: FaceBlock>(&self, blocks: &[B], values: &mut Vec<f64>) {
        self.assemble_with_edges(blocks, &[], values)
    }

    /// [`Pattern::assemble`] with one 8x8 block per edge of [`Pattern::with_edges`].
    pub fn assemble_with_edges<B: FaceBlock>(&self, blocks: &[B], edge_blocks: &[Matrix8], values: &mut Vec<f64>) {
        assert_eq!(blocks.len(), self.scatter.len(), "one block per element");
        assert_eq!(edge_blocks.len(), self.edge_scatter.len(), "one block per edge");
        let faces = blocks.len();
        values.resize(self.nnz(), 0.0);
        values.par_chunks_mut(self.chunk).enumerate().for_each(|(c, chunk)| {
            chunk.fill(0.0);
            let lo = c * self.chunk;
            let owned = lo..lo + chunk.len();
            for &e in &self.chunk_elements[self.chunk_ptr[c]..self.chunk_ptr[c + 1]] {
                let e = e as usize;
                if e < faces {
                    let b = &blocks[e];
                    for (k, &slot) in self.scatter[e].iter().enumerate() {
                        if owned.contains(&(slot as usize)) {
                            chunk[slot as usize - lo] += b.lower(k);
                        }
                    }
                } else {
                    let b = &edge_blocks[e - faces];
                    for (&(i, j), &slot) in LOWER8.iter().zip(&self.edge_scatter[e - faces]) {
                        if owned.contains(&(slot as usize)) {
                            chunk[slot as usize - lo] += b[(i, j)];
                        }
                    }
                }
            }
        });
    }

    /// `y = A x` for the symmetric matrix stored as its lower triangle.
    pub fn sym_mul(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for c in 0..self.n {
            let range = self.col_ptr[c]..self.col_ptr[c + 1];
            for (&r, &a) in self.row_idx[range.clone()].iter().zip(&values[range]) {
                y[r] += a * x[c];
                if r != c {
                    y[c] += a * x[r];
                }
            }
        }
        y
    }
}

/// Rows per parallel task of [`SymmetricRows::mul`].
const ROWS_PER_TASK: usize = 4096;

/// Both triangles of a [`Pattern`] row by row, each entry naming its lower-triangle value slot:
/// a product with the symmetric matrix sums each row in its own order, in parallel over rows,
/// so it has the same bits for any thread count (a product from the lower triangle alone
/// scatters into other rows). The truncated Newton step multiplies by the system with it.
#[derive(Clone, Debug)]
pub struct SymmetricRows {
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    /// The lower-triangle value slot of each entry.
    slot: Vec<u32>,
}

impl SymmetricRows {
    /// Both triangles of `pattern`, each row's columns sorted.
    pub fn new(pattern: &Pattern) -> SymmetricRows {
        let n = pattern.n;
        let mut count = vec![0usize; n + 1];
        for c in 0..n {
            for &r in &pattern.row_idx[pattern.col_ptr[c]..pattern.col_ptr[c + 1]] {
                count[r + 1] += 1;
                if r != c {
                    count[c + 1] += 1;
                }
            }
        }
        for r in 0..n {
            count[r + 1] += count[r];
        }
        let row_ptr = count;
        let mut fill = row_ptr.clone();
        let mut col = vec![0u32; row_ptr[n]];
        let mut slot = vec![0u32; row_ptr[n]];
        // Columns in increasing order: each row lists its columns sorted.
        for c in 0..n {
            for p in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                let r = pattern.row_idx[p];
                // (r, c) with r >= c goes to row r, its mirror to row c
                col[fill[r]] = c as u32;
                slot[fill[r]] = p as u32;
                fill[r] += 1;
                if r != c {
                    col[fill[c]] = r as u32;
                    slot[fill[c]] = p as u32;
                    fill[c] += 1;
                }
            }
        }
        SymmetricRows { row_ptr, col, slot }
    }

    /// `y = A x` for the symmetric matrix whose lower triangle `values` is on the pattern.
    pub fn mul(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(k, rows)| {
            let first = k * ROWS_PER_TASK;
            for (i, yr) in rows.iter_mut().enumerate() {
                let range = self.row_ptr[first + i]..self.row_ptr[first + i + 1];
                *yr = self.col[range.clone()]
                    .iter()
                    .zip(&self.slot[range])
                    .map(|(&c, &s)| values[s as usize] * x[c as usize])
                    .sum();
            }
        });
    }
}

/// The lower triangle's CSC structure (`col_ptr`, `row_idx`, rows sorted) of the `n x n`
/// matrix the faces' 6x6 and the edges' 8x8 element blocks write to, diagonal included.
fn lower_pattern(faces: &[[usize; 3]], edges: &[[usize; 4]], n: usize) -> (Vec<usize>, Vec<usize>) {
    // column -> rows (row >= col)
    let mut cols: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (c, col) in cols.iter_mut().enumerate() {
        col.push(c as u32);
    }
    for f in faces {
        let d = local_dofs(f);
        for &(a, b) in LOWER.iter() {
            let (r, c) = if d[a] >= d[b] { (d[a], d[b]) } else { (d[b], d[a]) };
            cols[c].push(r as u32);
        }
    }
    for e in edges {
        let d = edge_dofs(e);
        for &(a, b) in LOWER8.iter() {
            let (r, c) = if d[a] >= d[b] { (d[a], d[b]) } else { (d[b], d[a]) };
            cols[c].push(r as u32);
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0);
    for col in cols.iter_mut() {
        col.sort_unstable();
        col.dedup();
        row_idx.extend(col.iter().map(|&r| r as usize));
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assembled_matrix_equals_dense_sum_of_blocks() {
        let faces = vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]];
        let nv = 6; // vertex 5 unreferenced: still gets diagonal slots
        let pat = Pattern::new(&faces, nv);
        let blocks: Vec<Matrix6<f64>> = (0..faces.len())
            .map(|t| {
                let a = Matrix6::from_fn(|i, j| ((i * 7 + j * 3 + t * 5) % 11) as f64 - 4.0);
                a + a.transpose()
            })
            .collect();
        let mut vals = Vec::new();
        pat.assemble(&blocks, &mut vals);
        let n = 2 * nv;
        let mut dense = vec![vec![0.0; n]; n];
        for (f, b) in faces.iter().zip(&blocks) {
            let d = local_dofs(f);
            for a in 0..6 {
                for c in 0..6 {
                    dense[d[a]][d[c]] += b[(a, c)];
                }
            }
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let y = pat.sym_mul(&vals, &x);
        for r in 0..n {
            let yr: f64 = (0..n).map(|c| dense[r][c] * x[c]).sum();
            assert!((yr - y[r]).abs() < 1e-12);
        }
        assert_eq!(pat.diag.len(), n);
        // the parallel assembly equals a sequential scatter, bit for bit
        let mut seq = vec![0.0; pat.nnz()];
        for (b, s) in blocks.iter().zip(&pat.scatter) {
            for (k, &(i, j)) in LOWER.iter().enumerate() {
                seq[s[k] as usize] += b[(i, j)];
            }
        }
        assert_eq!(seq, vals);
        // lower triangle only
        for c in 0..n {
            for p in pat.col_ptr[c]..pat.col_ptr[c + 1] {
                assert!(pat.row_idx[p] >= c);
            }
        }
    }

    #[test]
    fn edge_blocks_assemble_like_a_dense_sum() {
        let faces = vec![[0, 1, 2], [1, 3, 2]];
        let edges = vec![[1, 2, 0, 3]];
        let pat = Pattern::with_edges(&faces, &edges, 4);
        let blocks: Vec<Matrix6<f64>> = (0..2)
            .map(|t| Matrix6::from_fn(|i, j| ((i + j + t) % 5) as f64 + if i == j { 9.0 } else { 0.0 }))
            .collect();
        let a = Matrix8::from_fn(|i, j| ((i * j + 3) % 7) as f64 - 2.0 + if i == j { 20.0 } else { 0.0 });
        let eb = vec![(a + a.transpose()) * 0.5];
        let mut vals = Vec::new();
        pat.assemble_with_edges(&blocks, &eb, &mut vals);
        let mut dense = vec![vec![0.0; 8]; 8];
        for (f, b) in faces.iter().zip(&blocks) {
            let d = local_dofs(f);
            for a in 0..6 {
                for c in 0..6 {
                    dense[d[a]][d[c]] += b[(a, c)];
                }
            }
        }
        let d = edge_dofs(&edges[0]);
        for a in 0..8 {
            for c in 0..8 {
                dense[d[a]][d[c]] += eb[0][(a, c)];
            }
        }
        // vertices 0 and 3 are coupled only through the edge block
        let x: Vec<f64> = (0..8).map(|i| (i as f64 * 0.61).cos()).collect();
        let y = pat.sym_mul(&vals, &x);
        for r in 0..8 {
            let yr: f64 = (0..8).map(|c| dense[r][c] * x[c]).sum();
            assert!((yr - y[r]).abs() < 1e-12, "{r}");
        }
        assert!(pat.nnz() > Pattern::new(&faces, 4).nnz());
        // the row view multiplies by the same matrix
        let mut z = vec![f64::NAN; 8];
        SymmetricRows::new(&pat).mul(&vals, &x, &mut z);
        for r in 0..8 {
            assert!((z[r] - y[r]).abs() < 1e-12, "{r}");
        }
    }

    /// The row view's product equals the lower triangle's on a mesh of several row chunks, and
    /// has the same bits on 1 and 4 threads.
    #[test]
    fn the_row_view_multiplies_like_the_lower_triangle_on_any_thread_count() {
        let mesh = crate::generate::generate("bumpy_10k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        assert!(pat.n > 4 * ROWS_PER_TASK);
        let vals: Vec<f64> = (0..pat.nnz()).map(|k| (k * 37 % 101) as f64 / 50.0 - 1.0).collect();
        let x: Vec<f64> = (0..pat.n).map(|i| (i as f64 * 0.37).sin()).collect();
        let want = pat.sym_mul(&vals, &x);
        let rows = SymmetricRows::new(&pat);
        let mul_on = |threads: usize| {
            let mut y = vec![0.0; pat.n];
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| rows.mul(&vals, &x, &mut y));
            y
        };
        let one = mul_on(1);
        for (a, b) in one.iter().zip(&want) {
            assert!((a - b).abs() < 1e-12 * (1.0 + b.abs()), "{a} {b}");
        }
        assert_eq!(one, mul_on(4));
    }

    #[test]
    fn parallel_assembly_is_bitwise_sequential_scatter_on_a_large_mesh() {
        let mesh = crate::generate::generate("bumpy_10k").unwrap();
        // chunks of 4096 slots: the mesh's ~140k slots make many (the default makes one)
        let pat = Pattern::chunked(&mesh.faces, &[], mesh.n_vertices(), 4096);
        let blocks: Vec<Matrix6<f64>> = (0..mesh.n_faces())
            .map(|t| Matrix6::from_fn(|i, j| ((i * 13 + j * 7 + t * 31) % 17) as f64 / 7.0 + 1.0 / (1.0 + t as f64)))
            .collect();
        let mut seq = vec![0.0; pat.nnz()];
        for (b, s) in blocks.iter().zip(&pat.scatter) {
            for (k, &(i, j)) in LOWER.iter().enumerate() {
                seq[s[k] as usize] += b[(i, j)];
            }
        }
        let mut vals = vec![f64::NAN; 3]; // stale contents are overwritten
        let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        pool.install(|| pat.assemble(&blocks, &mut vals));
        assert!(pat.nnz() > 16 * pat.chunk, "several chunks");
        assert_eq!(Pattern::new(&mesh.faces, mesh.n_vertices()).row_idx, pat.row_idx);
        assert_eq!(seq, vals);
        // packed lower triangles assemble to the same bits
        let packed: Vec<Lower6> = blocks.iter().map(pack_lower).collect();
        let mut from_packed = Vec::new();
        pat.assemble(&packed, &mut from_packed);
        assert_eq!(seq, from_packed);

        // with edge blocks: four vertices, a face and one vertex of a face further on
        let edges: Vec<[usize; 4]> = (0..mesh.n_faces() - 7)
            .filter_map(|t| {
                let (f, g) = (mesh.faces[t], mesh.faces[t + 7]);
                g.iter().find(|v| !f.contains(v)).map(|&v| [f[0], f[1], f[2], v])
            })
            .collect();
        let pat = Pattern::chunked(&mesh.faces, &edges, mesh.n_vertices(), 4096);
        let edge_blocks: Vec<Matrix8> =
            (0..edges.len()).map(|e| Matrix8::from_fn(|i, j| ((i * 5 + j * 11 + e * 3) % 13) as f64 / 3.0)).collect();
        let mut seq = vec![0.0; pat.nnz()];
        for (b, s) in blocks.iter().zip(&pat.scatter) {
            for (k, &(i, j)) in LOWER.iter().enumerate() {
                seq[s[k] as usize] += b[(i, j)];
            }
        }
        for (b, s) in edge_blocks.iter().zip(&pat.edge_scatter) {
            for (k, &(i, j)) in LOWER8.iter().enumerate() {
                seq[s[k] as usize] += b[(i, j)];
            }
        }
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| pat.assemble_with_edges(&blocks, &edge_blocks, &mut vals));
            assert_eq!(seq, vals, "{threads} threads");
        }
    }
}
