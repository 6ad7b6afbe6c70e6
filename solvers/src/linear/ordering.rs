//! Fill-reducing orderings for the sparse Cholesky factorization.
//!
//! faer ships AMD only. Nested dissection (METIS `NodeND`) of the vertex graph cuts the fill
//! and the flops at mesh sizes of 50k+ vertices (docs/src/design/linear-algebra.md;
//! our timings against Pardiso: docs/src/results/linear-solvers.md). Two details
//! matter:
//! - The graph is the *vertex* graph (the two dofs of a vertex share one node), expanded to
//!   the dofs afterwards: the same fill as ordering the dof graph, in less time.
//! - The order is postordered along the elimination tree before faer sees it: faer merges
//!   only contiguous columns into supernodes, and raw METIS output gives many more
//!   supernodes and a slower factorization than AMD.

use super::error::LinearError;
use crate::grouping::grouped;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The fill-reducing ordering of the Cholesky factorization (`[linear] ordering`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Ordering {
    /// faer's approximate minimum degree.
    Amd,
    /// METIS nested dissection of the vertex graph, postordered (the default: faster to
    /// factorize on all but small meshes; `benches/pipeline.rs` compares the two).
    #[default]
    Metis,
}

impl Ordering {
    /// The name in configs (`amd`, `metis`).
    pub fn as_str(&self) -> &'static str {
        match self {
            Ordering::Amd => "amd",
            Ordering::Metis => "metis",
        }
    }
}

/// Graphs with fewer nodes than this use AMD whatever the setting: nested dissection has
/// nothing to gain there, and METIS rejects some degenerate tiny graphs.
pub const METIS_MIN_NODES: usize = 64;

/// METIS keeps some state in globals of GKlib (error trapping); one call at a time.
static METIS_LOCK: Mutex<()> = Mutex::new(());

/// A permutation as `(fwd, inv)`: `fwd[new] = old`, `inv[old] = new`.
pub type Permutation = (Vec<usize>, Vec<usize>);

/// `inv` of the permutation `fwd` (`fwd[new] = old`, `inv[old] = new`).
pub(crate) fn inverse(fwd: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; fwd.len()];
    for (new, &old) in fwd.iter().enumerate() {
        inv[old] = new;
    }
    inv
}

/// A METIS nested-dissection order of the symmetric matrix whose lower triangle is the CSC
/// pattern (`col_ptr`, `row_idx`), on the graph whose nodes are groups of `block`
/// consecutive dofs, then postordered. Returns `(fwd, inv)` with `fwd[new] = old`.
/// `None` when the graph is too small for nested dissection to pay.
pub fn metis_order(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    block: usize,
) -> Result<Option<Permutation>, LinearError> {
    metis_order_timed(n, col_ptr, row_idx, block).map(|(perm, _)| perm)
}

/// [`metis_order`], also returning how long the call waited for another thread's METIS
/// call (`METIS_LOCK`), so the analysis time can leave the wait out.
pub fn metis_order_timed(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    block: usize,
) -> Result<(Option<Permutation>, Duration), LinearError> {
    let block = block.max(1);
    if !n.is_multiple_of(block) {
        return Err(LinearError::Symbolic(format!("{n} dofs are not a multiple of the block size {block}")));
    }
    let nodes = n / block;
    if nodes < METIS_MIN_NODES {
        return Ok((None, Duration::ZERO));
    }
    let (xadj, adjncy) = node_graph(nodes, col_ptr, row_idx, block);
    let (node_fwd, waited) = node_nd(nodes, xadj, adjncy)?;
    let mut fwd = Vec::with_capacity(n);
    for &v in &node_fwd {
        fwd.extend((0..block).map(|j| block * v + j));
    }
    let fwd = postorder(n, col_ptr, row_idx, &fwd);
    let inv = inverse(&fwd);
    Ok((Some((fwd, inv)), waited))
}

/// The adjacency (METIS CSR: `xadj`, `adjncy`, no self loops, both directions) of the node
/// graph: node `c / block` is adjacent to `r / block` for every stored entry `(r, c)`.
/// Grouped by node with a counting pass rather than a vector per node: at a million nodes the
/// allocations dominated the ordering's setup.
fn node_graph(nodes: usize, col_ptr: &[usize], row_idx: &[usize], block: usize) -> (Vec<i32>, Vec<i32>) {
    let (start, all) = grouped(nodes, || {
        (0..col_ptr.len() - 1)
            .flat_map(move |c| row_idx[col_ptr[c]..col_ptr[c + 1]].iter().map(move |&r| (c / block, r / block)))
            .filter(|(a, b)| a != b)
            .flat_map(|(a, b)| [(a, b as i32), (b, a as i32)])
    });
    let mut xadj = Vec::with_capacity(nodes + 1);
    let mut adjncy = Vec::with_capacity(all.len());
    xadj.push(0);
    for k in 0..nodes {
        let group = &all[start[k]..start[k + 1]];
        // sorted: the first of each run of equal neighbours
        adjncy.extend(group.iter().enumerate().filter(|&(i, v)| i == 0 || group[i - 1] != *v).map(|(_, &v)| v));
        xadj.push(adjncy.len() as i32);
    }
    (xadj, adjncy)
}

/// `METIS_NodeND` with default options (deterministic: METIS seeds its generator with a
/// fixed value). Returns `fwd[new] = old` and the time spent waiting for [`METIS_LOCK`].
fn node_nd(nodes: usize, mut xadj: Vec<i32>, mut adjncy: Vec<i32>) -> Result<(Vec<usize>, Duration), LinearError> {
    let too_big = |_| LinearError::Symbolic(format!("{nodes} nodes exceed METIS's 32-bit indices"));
    let mut nvtxs: i32 = nodes.try_into().map_err(too_big)?;
    i32::try_from(adjncy.len()).map_err(too_big)?;
    let mut perm = vec![0i32; nodes];
    let mut iperm = vec![0i32; nodes];
    let t_lock = Instant::now();
    let waited;
    let status = {
        let _guard = METIS_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        waited = t_lock.elapsed();
        // SAFETY: `xadj` has `nvtxs + 1` entries and `adjncy` `xadj[nvtxs]` entries, all in
        // `0..nvtxs` (built by `node_graph`); `perm` and `iperm` have `nvtxs` entries; null
        // `vwgt` and `options` ask for unit weights and METIS's defaults. METIS only reads
        // the graph and writes the two permutations.
        unsafe {
            metis_sys::METIS_NodeND(
                &mut nvtxs,
                xadj.as_mut_ptr(),
                adjncy.as_mut_ptr(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                perm.as_mut_ptr(),
                iperm.as_mut_ptr(),
            )
        }
    };
    if status != metis_sys::rstatus_et_METIS_OK {
        return Err(LinearError::Symbolic(format!("METIS_NodeND failed with status {status}")));
    }
    // METIS: row i of the permuted matrix is row perm[i] of the original.
    let fwd: Vec<usize> = perm.iter().map(|&p| p as usize).collect();
    let mut seen = vec![false; nodes];
    for &p in &fwd {
        if p >= nodes || std::mem::replace(&mut seen[p], true) {
            return Err(LinearError::Symbolic("METIS_NodeND returned an invalid permutation".into()));
        }
    }
    Ok((fwd, waited))
}

/// Compose `fwd` with a postorder of the elimination tree of the permuted matrix, so that
/// every subtree is numbered contiguously (Liu's etree algorithm with path compression, then
/// an iterative depth-first search visiting children in increasing order).
pub(crate) fn postorder(n: usize, col_ptr: &[usize], row_idx: &[usize], fwd: &[usize]) -> Vec<usize> {
    let inv = inverse(fwd);
    // Neighbours of each new index with a smaller new index (row k of the permuted lower
    // triangle; grouped with a counting pass, not a vector per row, for the same reason).
    let inv = &inv;
    let (row_start, below) = grouped(n, || {
        (0..n)
            .flat_map(move |c| row_idx[col_ptr[c]..col_ptr[c + 1]].iter().map(move |&r| (inv[r], inv[c])))
            .filter(|(a, b)| a != b)
            .map(|(a, b)| (a.max(b), a.min(b)))
    });
    const NONE: usize = usize::MAX;
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for k in 0..n {
        for &j0 in &below[row_start[k]..row_start[k + 1]] {
            let mut j = j0;
            while ancestor[j] != NONE && ancestor[j] != k {
                let next = ancestor[j];
                ancestor[j] = k;
                j = next;
            }
            if ancestor[j] == NONE {
                ancestor[j] = k;
                parent[j] = k;
            }
        }
    }
    let (child_start, children) =
        grouped(n, || parent.iter().enumerate().filter(|(_, &p)| p != NONE).map(|(j, &p)| (p, j)));
    let mut out = Vec::with_capacity(n);
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push((root, 0));
        while let Some((node, next)) = stack.pop() {
            if let Some(&child) = children[child_start[node]..child_start[node + 1]].get(next) {
                stack.push((node, next + 1));
                stack.push((child, 0));
            } else {
                out.push(fwd[node]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assembly::Pattern;

    fn is_permutation(p: &[usize]) -> bool {
        let mut seen = vec![false; p.len()];
        p.iter().all(|&i| i < p.len() && !std::mem::replace(&mut seen[i], true))
    }

    #[test]
    fn metis_order_is_a_deterministic_blockwise_permutation() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        let (fwd, inv) = metis_order(pat.n, &pat.col_ptr, &pat.row_idx, 2).unwrap().unwrap();
        assert!(is_permutation(&fwd));
        assert!(fwd.iter().enumerate().all(|(new, &old)| inv[old] == new));
        // the two dofs of a vertex stay together, u before v
        for pair in fwd.chunks_exact(2) {
            assert_eq!((pair[0] % 2, pair[1]), (0, pair[0] + 1));
        }
        assert_eq!(metis_order(pat.n, &pat.col_ptr, &pat.row_idx, 2).unwrap().unwrap().0, fwd);
        assert!(metis_order(pat.n, &pat.col_ptr, &pat.row_idx, 3).is_err());
    }

    /// Parent of each column in the elimination tree of the pattern permuted by `fwd`.
    fn etree_parents(pat: &Pattern, fwd: &[usize]) -> Vec<Option<usize>> {
        // The same tree from a dense symbolic elimination: parent(j) = min { i > j : L(i, j) != 0 }.
        let n = pat.n;
        let inv = inverse(fwd);
        let mut rows: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); n];
        for c in 0..n {
            for &r in &pat.row_idx[pat.col_ptr[c]..pat.col_ptr[c + 1]] {
                let (a, b) = (inv[r].max(inv[c]), inv[r].min(inv[c]));
                if a != b {
                    rows[b].insert(a);
                }
            }
        }
        let mut parent = vec![None; n];
        for j in 0..n {
            let first = rows[j].iter().next().copied();
            parent[j] = first;
            if let Some(p) = first {
                let rest: Vec<usize> = rows[j].iter().copied().filter(|&i| i != p).collect();
                rows[p].extend(rest);
            }
        }
        parent
    }

    #[test]
    fn the_order_is_postordered_along_the_elimination_tree() {
        // Small enough for the dense symbolic elimination oracle.
        let mesh = crate::generate::generate("flat_disk_1k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        let (fwd, _) = metis_order(pat.n, &pat.col_ptr, &pat.row_idx, 2).unwrap().unwrap();
        let parent = etree_parents(&pat, &fwd);
        // In a postorder the subtree of j is exactly the range [j - size(j) + 1, j].
        let n = pat.n;
        let mut size = vec![1usize; n];
        for (j, p) in parent.iter().enumerate() {
            if let Some(p) = *p {
                assert!(p > j);
                size[p] += size[j];
            }
        }
        let is_ancestor = |a: usize, mut i: usize| loop {
            if i == a {
                return true;
            }
            match parent[i] {
                Some(q) if q <= a => i = q,
                _ => return false,
            }
        };
        for (j, &sz) in size.iter().enumerate() {
            assert!((j + 1 - sz..=j).all(|i| is_ancestor(j, i)), "subtree of {j} is not contiguous");
        }
        // and not every tree is trivially a path: the order has real branching
        assert!(parent.iter().flatten().collect::<std::collections::HashSet<_>>().len() < n - 1);
    }

    #[test]
    fn tiny_graphs_fall_back_to_amd() {
        let faces = vec![[0, 1, 2], [0, 2, 3]];
        let pat = Pattern::new(&faces, 4);
        assert_eq!(metis_order(pat.n, &pat.col_ptr, &pat.row_idx, 2).unwrap(), None);
    }

    /// The node graph is every off-block entry's pair of nodes, both ways, once each, sorted.
    #[test]
    fn the_node_graph_is_the_sorted_adjacency_of_the_blocks() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        for block in [1, 2] {
            let nodes = pat.n / block;
            let mut oracle: Vec<std::collections::BTreeSet<i32>> = vec![Default::default(); nodes];
            for c in 0..pat.n {
                for &r in &pat.row_idx[pat.col_ptr[c]..pat.col_ptr[c + 1]] {
                    if r / block != c / block {
                        oracle[r / block].insert((c / block) as i32);
                        oracle[c / block].insert((r / block) as i32);
                    }
                }
            }
            let (xadj, adjncy) = node_graph(nodes, &pat.col_ptr, &pat.row_idx, block);
            assert_eq!(xadj.len(), nodes + 1);
            for (v, set) in oracle.iter().enumerate() {
                let row = &adjncy[xadj[v] as usize..xadj[v + 1] as usize];
                assert!(row.iter().eq(set.iter()), "block {block}, node {v}");
            }
        }
    }
}
