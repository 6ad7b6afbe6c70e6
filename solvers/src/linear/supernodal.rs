//! The numeric supernodal Cholesky factorization, parallel over the elimination tree.
//!
//! faer's supernodal factorization visits the supernodes one after the other and can only
//! parallelize the dense kernels inside each, and on the 2D meshes' nested-dissection
//! orderings most supernodes are small (docs/src/results/parallel-factorization.md).
//! Two supernodes in disjoint subtrees of the supernodal elimination tree read only their
//! own descendants and write only their own columns, so whole subtrees can be factorized
//! at once. This module computes the same left-looking factorization as faer, into faer's
//! layout of the values (supernode after supernode, each a column-major block of its
//! columns and then its pattern's rows), so the solves (`triangular`'s, or faer's for
//! `time-system --kernel faer`) use the factor as is:
//!
//! - every entry of `A` goes to its slot of the factor through a map computed once per
//!   analysis (the permutation and the supernode layout folded together);
//! - supernode `s` subtracts `L_d[rows >= s] L_d[rows of s]^T` for each descendant `d` whose
//!   pattern meets its columns (in increasing `d`), factorizes its diagonal block densely and
//!   solves its rows below: `L_bot = A_bot L_top^-T`;
//! - the supernodes are numbered in a postorder (checked when the schedule is built), so a
//!   subtree is a contiguous run of supernodes and of values: sibling subtrees are split off
//!   the values with `split_at_mut` and factorized with `rayon::join` while they are large
//!   enough to be worth a task.
//!
//! Inside a task every supernode is computed by sequential dense kernels; the supernodes
//! above all tasks (the top separators, whose dense blocks are the largest) run their dense
//! kernels on all the pool's threads. Every supernode applies its updates in the same order
//! whoever computes it, and faer's parallel dense kernels split the output, not the sums,
//! so the factor is the same bits on every call and for every thread count
//! (`tests::factor_is_deterministic_and_the_same_for_every_thread_count`, 1 to 4 threads;
//! also checked on bumpy_200k, 1 against 2 threads).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch, LltError, LltRegularization};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::perm::PermRef;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};
use std::sync::Mutex;

const NONE: usize = usize::MAX;

/// What the parallel factorization needs beyond faer's symbolic factor, computed once per
/// analysis.
#[derive(Debug)]
pub struct Schedule {
    /// For each supernode, the descendants whose pattern meets its columns, increasing.
    update_ptr: Vec<usize>,
    updates: Vec<usize>,
    /// Children of each supernode in the supernodal elimination tree, increasing, and the
    /// roots of the forest.
    child_ptr: Vec<usize>,
    children: Vec<usize>,
    roots: Vec<usize>,
    /// First supernode of each supernode's subtree (the subtree is `first[s]..=s`).
    first: Vec<usize>,
    /// Flops estimate of each subtree, for deciding what is worth a task.
    work: Vec<f64>,
    /// Slot in the factor's values of each stored entry of the lower triangle of `A`.
    a_to_l: Vec<usize>,
    /// Largest diagonal block (for the dense Cholesky's scratch).
    max_cols: usize,
}

/// Why a schedule could not be built (the analysis postorders an order it refuses as
/// [`ScheduleError::NotPostordered`]; the other reasons are errors of the analysis).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ScheduleError {
    /// The supernodes are not numbered in a postorder of their tree.
    NotPostordered,
    /// An entry of `A` has no slot in the factor (the pattern is not the analysed one).
    NotInPattern {
        /// Row of the entry in the unpermuted `A`.
        row: usize,
        /// Column of the entry in the unpermuted `A`.
        col: usize,
    },
}

/// The columns `begin..end` of supernode `s`.
pub(crate) fn s_range(sym: &SymbolicSupernodalCholesky<usize>, s: usize) -> (usize, usize) {
    (sym.supernode_begin()[s], sym.supernode_end()[s])
}

/// The rows of supernode `s` below its columns.
pub(crate) fn s_pattern(sym: &SymbolicSupernodalCholesky<usize>, s: usize) -> &[usize] {
    &sym.row_idx()[sym.col_ptr_for_row_idx()[s]..][..sym.nnz_per_super()[s]]
}

/// The slot in `L`'s values of every entry of `A`'s lower triangle (`col_ptr`, `row_idx`,
/// unpermuted; `perm` as in [`Schedule::new`]), in `A`'s order; `super_of` maps a column of the
/// permuted matrix to its supernode.
fn entry_slots(
    sym: &SymbolicSupernodalCholesky<usize>,
    perm: Option<PermRef<'_, usize>>,
    col_ptr: &[usize],
    row_idx: &[usize],
    super_of: &[usize],
) -> Result<Vec<usize>, ScheduleError> {
    let inv = perm.map(|p| p.arrays().1);
    let new = |i: usize| inv.map_or(i, |inv| inv[i]);
    let mut a_to_l = Vec::with_capacity(row_idx.len());
    for j in 0..col_ptr.len() - 1 {
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            let (pi, pj) = (new(i), new(j));
            let (r, c) = if pi >= pj { (pi, pj) } else { (pj, pi) };
            let s = super_of[c];
            let (b, e) = s_range(sym, s);
            let pat = s_pattern(sym, s);
            let local = if r < e {
                r - b
            } else {
                match pat.binary_search(&r) {
                    Ok(k) => e - b + k,
                    Err(_) => return Err(ScheduleError::NotInPattern { row: i, col: j }),
                }
            };
            let nrows = e - b + pat.len();
            a_to_l.push(sym.col_ptr_for_val()[s] + (c - b) * nrows + local);
        }
    }
    Ok(a_to_l)
}

impl Schedule {
    /// The schedule of `sym` for the lower-triangle CSC pattern `(col_ptr, row_idx)` of the
    /// unpermuted matrix, factorized as `P A P^T` with `perm` (`None`: the identity).
    pub fn new(
        sym: &SymbolicSupernodalCholesky<usize>,
        perm: Option<PermRef<'_, usize>>,
        col_ptr: &[usize],
        row_idx: &[usize],
    ) -> Result<Schedule, ScheduleError> {
        let ns = sym.n_supernodes();
        let n = sym.nrows();
        let mut super_of = vec![0usize; n];
        for s in 0..ns {
            let (b, e) = s_range(sym, s);
            super_of[b..e].fill(s);
        }
        // Tree: the parent of d is the supernode of its pattern's first row.
        let parent: Vec<usize> = (0..ns).map(|d| s_pattern(sym, d).first().map_or(NONE, |&r| super_of[r])).collect();
        let mut upd: Vec<Vec<usize>> = vec![Vec::new(); ns];
        for d in 0..ns {
            let pat = s_pattern(sym, d);
            let mut last = NONE;
            for &r in pat {
                let s = super_of[r];
                if s != last {
                    upd[s].push(d);
                    last = s;
                }
            }
        }
        let mut kids: Vec<Vec<usize>> = vec![Vec::new(); ns];
        let mut roots = Vec::new();
        for (s, &p) in parent.iter().enumerate() {
            match p {
                NONE => roots.push(s),
                p if p > s => kids[p].push(s),
                _ => return Err(ScheduleError::NotPostordered),
            }
        }
        // Postorder: every subtree is the contiguous run first[s]..=s.
        let mut first: Vec<usize> = (0..ns).collect();
        let mut size = vec![1usize; ns];
        let mut work = vec![0.0f64; ns];
        for s in 0..ns {
            let (b, e) = s_range(sym, s);
            let (c, r) = ((e - b) as f64, (e - b + sym.nnz_per_super()[s]) as f64);
            work[s] += c * r * r;
            if size[s] != s - first[s] + 1 {
                return Err(ScheduleError::NotPostordered);
            }
            if let Some(p) = (parent[s] != NONE).then_some(parent[s]) {
                first[p] = first[p].min(first[s]);
                size[p] += size[s];
                work[p] += work[s];
            }
        }
        let mut expected = 0;
        for &r in &roots {
            if first[r] != expected {
                return Err(ScheduleError::NotPostordered);
            }
            expected = r + 1;
        }
        let a_to_l = entry_slots(sym, perm, col_ptr, row_idx, &super_of)?;
        let csr = |lists: Vec<Vec<usize>>| {
            let mut ptr = vec![0];
            let mut flat = Vec::new();
            for l in lists {
                flat.extend(l);
                ptr.push(flat.len());
            }
            (ptr, flat)
        };
        let (update_ptr, updates) = csr(upd);
        let (child_ptr, children) = csr(kids);
        let max_cols = (0..ns).map(|s| s_range(sym, s)).map(|(b, e)| e - b).max().unwrap_or(0);
        Ok(Schedule { update_ptr, updates, child_ptr, children, roots, first, work, a_to_l, max_cols })
    }

    /// The children of supernode `s`, increasing.
    pub(crate) fn children(&self, s: usize) -> &[usize] {
        &self.children[self.child_ptr[s]..self.child_ptr[s + 1]]
    }

    /// The roots of the supernodal elimination forest, increasing.
    pub(crate) fn roots(&self) -> &[usize] {
        &self.roots
    }

    /// The first supernode of the subtree of `s` (the subtree is `first(s)..=s`).
    pub(crate) fn first(&self, s: usize) -> usize {
        self.first[s]
    }

    fn updates(&self, s: usize) -> &[usize] {
        &self.updates[self.update_ptr[s]..self.update_ptr[s + 1]]
    }
}

/// Per-thread scratch: the local row of each global row in the current supernode, the dense
/// update block and the dense Cholesky's stack.
struct Scratch {
    local: Vec<usize>,
    update: Vec<f64>,
    mem: MemBuffer,
}

impl Scratch {
    fn new(n: usize, max_cols: usize) -> Scratch {
        let req = cholesky_in_place_scratch::<f64>(max_cols, Par::Seq, Default::default());
        Scratch { local: vec![NONE; n], update: Vec::new(), mem: MemBuffer::new(req) }
    }
}

/// Scratch for each thread of the pool the factorization runs in, kept between calls.
#[derive(Default)]
pub struct Workspace {
    threads: Vec<Mutex<Scratch>>,
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Workspace({} threads)", self.threads.len())
    }
}

struct Ctx<'a> {
    sym: &'a SymbolicSupernodalCholesky<usize>,
    sched: &'a Schedule,
    ws: &'a Workspace,
    /// Subtrees with less work than this are factorized by one task.
    grain: f64,
}

/// Factorize the lower triangle `a_values` (on the pattern the schedule was built for) into
/// `l_values` (faer's layout for `sym`), on the threads of the calling rayon pool. Returns
/// the first non-positive pivot (a column of the permuted matrix) when `A` is not positive
/// definite.
pub fn factorize(
    sym: &SymbolicSupernodalCholesky<usize>,
    sched: &Schedule,
    ws: &mut Workspace,
    a_values: &[f64],
    l_values: &mut [f64],
) -> Result<(), LltError> {
    let threads = rayon::current_num_threads().max(1);
    let n = sym.nrows();
    while ws.threads.len() < threads {
        ws.threads.push(Mutex::new(Scratch::new(n, sched.max_cols)));
    }
    l_values.fill(0.0);
    for (&slot, &v) in sched.a_to_l.iter().zip(a_values) {
        l_values[slot] += v;
    }
    let total: f64 = sched.roots.iter().map(|&r| sched.work[r]).sum();
    // One task per thread is not enough to balance unequal subtrees; 16 per thread is
    // plenty (and sequential when there is one thread).
    let grain = if threads == 1 { f64::INFINITY } else { total / (16 * threads) as f64 };
    let ctx = Ctx { sym, sched, ws, grain };
    // Outside any task the supernodes (the top separators) get every thread of the pool in
    // their dense kernels.
    let par = if threads == 1 { Par::Seq } else { Par::rayon(threads) };
    forest(&ctx, &sched.roots, l_values, 0, par)
}

/// The subtrees of `roots` (consecutive in the postorder), whose values are `l` starting at
/// value index `base`; `par` is the dense kernels' parallelism (sequential inside a task).
fn forest(ctx: &Ctx, roots: &[usize], l: &mut [f64], base: usize, par: Par) -> Result<(), LltError> {
    match roots {
        [] => Ok(()),
        [s] => subtree(ctx, *s, l, base, par),
        _ => {
            let mid = roots.len() / 2;
            let split = ctx.sym.col_ptr_for_val()[ctx.sched.first[roots[mid]]] - base;
            let (left, right) = l.split_at_mut(split);
            let work = |rs: &[usize]| rs.iter().map(|&r| ctx.sched.work[r]).sum::<f64>();
            let (a, b) = (&roots[..mid], &roots[mid..]);
            let (ra, rb) = if work(a).min(work(b)) > ctx.grain {
                rayon::join(|| forest(ctx, a, left, base, Par::Seq), || forest(ctx, b, right, base + split, Par::Seq))
            } else {
                (forest(ctx, a, left, base, par), forest(ctx, b, right, base + split, par))
            };
            // The lower-numbered failure, as the sequential order would report it.
            ra.and(rb)
        }
    }
}

/// The subtree of `s`; `l` holds its values from value index `base`. A chain of
/// single-child supernodes (consecutive numbers, ending at `s`) is walked in a loop, not by
/// recursion, so a deep tree cannot exhaust a thread's stack.
fn subtree(ctx: &Ctx, s: usize, l: &mut [f64], base: usize, par: Par) -> Result<(), LltError> {
    let mut bottom = s;
    while let [only] = ctx.sched.children(bottom) {
        bottom = *only;
    }
    let ptr = ctx.sym.col_ptr_for_val();
    {
        let (below, _) = l.split_at_mut(ptr[bottom] - base);
        forest(ctx, ctx.sched.children(bottom), below, base, par)?;
    }
    for node in bottom..=s {
        let (done, rest) = l.split_at_mut(ptr[node] - base);
        supernode(ctx, node, done, base, &mut rest[..ptr[node + 1] - ptr[node]], par)?;
    }
    Ok(())
}

fn scratch<'a>(ctx: &'a Ctx) -> std::sync::MutexGuard<'a, Scratch> {
    let i = rayon::current_thread_index().unwrap_or(0) % ctx.ws.threads.len();
    // A thread runs one supernode at a time (no task is spawned inside one, and the dense
    // kernels run in parallel only outside every task, when no other supernode is pending),
    // so its slot is free; a poisoned slot only means a panic elsewhere, and every use
    // leaves the slot as it found it.
    ctx.ws.threads[i].lock().unwrap_or_else(|e| e.into_inner())
}

/// Supernode `s`: its descendants' values are `below` (from value index `base`), its own
/// block is `ls`, holding the entries of `A` on entry and its columns of `L` on exit.
fn supernode(ctx: &Ctx, s: usize, below: &[f64], base: usize, ls: &mut [f64], par: Par) -> Result<(), LltError> {
    let sym = ctx.sym;
    let (s_start, s_end) = s_range(sym, s);
    let s_pat = s_pattern(sym, s);
    let s_ncols = s_end - s_start;
    let s_nrows = s_ncols + s_pat.len();
    let mut guard = scratch(ctx);
    let Scratch { local, update, mem } = &mut *guard;
    for (k, &r) in s_pat.iter().enumerate() {
        local[r] = s_ncols + k;
    }
    for &d in ctx.sched.updates(s) {
        let (d_start, d_end) = s_range(sym, d);
        let d_pat = s_pattern(sym, d);
        let d_ncols = d_end - d_start;
        let d_nrows = d_ncols + d_pat.len();
        let off = sym.col_ptr_for_val()[d] - base;
        let ld = MatRef::from_column_major_slice(&below[off..off + d_nrows * d_ncols], d_nrows, d_ncols);
        // d's rows from s's first column on, and those of them that are s's columns.
        let p0 = d_pat.partition_point(|&r| r < s_start);
        let mid = d_pat[p0..].partition_point(|&r| r < s_end);
        let rows = &d_pat[p0..];
        let nb = rows.len();
        let (lhs_top, lhs_bot) = ld.subrows(d_ncols + p0, nb).split_at_row(mid);
        update.clear();
        update.resize(nb * mid, 0.0);
        let w = MatMut::from_column_major_slice_mut(update, nb, mid);
        let (w_top, w_bot) = w.split_at_row_mut(mid);
        // Only the lower triangle of the block on s's own columns is used.
        triangular::matmul(
            w_top,
            BlockStructure::TriangularLower,
            Accum::Replace,
            lhs_top,
            BlockStructure::Rectangular,
            lhs_top.transpose(),
            BlockStructure::Rectangular,
            1.0,
            par,
        );
        matmul(w_bot, Accum::Replace, lhs_bot, lhs_top.transpose(), 1.0, par);
        for (j, &cj) in rows[..mid].iter().enumerate() {
            let col = &mut ls[(cj - s_start) * s_nrows..][..s_nrows];
            let wj = &update[j * nb..][..nb];
            for (&ri, &v) in rows[j..mid].iter().zip(&wj[j..mid]) {
                col[ri - s_start] -= v;
            }
            for (&ri, &v) in rows[mid..].iter().zip(&wj[mid..]) {
                col[local[ri]] -= v;
            }
        }
    }
    for &r in s_pat {
        local[r] = NONE;
    }
    let ls = MatMut::from_column_major_slice_mut(ls, s_nrows, s_ncols);
    let (mut top, bot) = ls.split_at_row_mut(s_ncols);
    cholesky_in_place(top.rb_mut(), LltRegularization::default(), par, MemStack::new(mem), Default::default())
        .map_err(|LltError::NonPositivePivot { index }| LltError::NonPositivePivot { index: index + s_start })?;
    solve_lower_triangular_in_place(top.rb(), bot.transpose_mut(), par);
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::assembly::Pattern;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
    use faer::Side;

    /// The Newton pattern of a ring disk with SPD values: a graph Laplacian of the two
    /// interleaved dofs plus a diagonal, with coupling between the dofs of a vertex.
    pub(crate) fn system(mesh: &str) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let mesh = crate::generate::generate(mesh).unwrap();
        system_of(Pattern::new(&mesh.faces, mesh.n_vertices()))
    }

    fn system_of(pat: Pattern) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let col_of: Vec<usize> =
            (0..pat.n).flat_map(|c| std::iter::repeat_n(c, pat.col_ptr[c + 1] - pat.col_ptr[c])).collect();
        let mut vals: Vec<f64> = pat
            .row_idx
            .iter()
            .zip(&col_of)
            .map(|(&r, &c)| if r == c { 0.0 } else { -0.1 - 0.01 * ((r * 7 + c * 3) % 11) as f64 })
            .collect();
        // Diagonally dominant: the diagonal exceeds the sum of |off-diagonals| of its row.
        let mut rowsum = vec![0.0; pat.n];
        for ((&r, &c), v) in pat.row_idx.iter().zip(&col_of).zip(&vals) {
            if r != c {
                rowsum[r] += v.abs();
                rowsum[c] += v.abs();
            }
        }
        for (c, &p) in pat.diag.iter().enumerate() {
            vals[p] = rowsum[c] + 1.0 + (c % 5) as f64;
        }
        (pat.n, pat.col_ptr, pat.row_idx, vals)
    }

    /// AMD and a supernodal factor whatever its size.
    pub(crate) fn analyse(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
    ) -> (SymbolicSparseColMat<usize>, SymbolicCholesky<usize>) {
        let a = SymbolicSparseColMat::<usize>::new_checked(n, n, col_ptr.to_vec(), None, row_idx.to_vec());
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let sym = factorize_symbolic_cholesky(a.as_ref(), Side::Lower, SymmetricOrdering::Amd, params).unwrap();
        (a, sym)
    }

    pub(crate) fn supernodal(sym: &SymbolicCholesky<usize>) -> &SymbolicSupernodalCholesky<usize> {
        match sym.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            SymbolicCholeskyRaw::Simplicial(_) => panic!("expected a supernodal analysis"),
        }
    }

    fn ours(
        sym: &SymbolicCholesky<usize>,
        col_ptr: &[usize],
        row_idx: &[usize],
        vals: &[f64],
        threads: usize,
    ) -> Vec<f64> {
        let sn = supernodal(sym);
        let sched = Schedule::new(sn, sym.perm(), col_ptr, row_idx).unwrap();
        let mut ws = Workspace::default();
        let mut l = vec![f64::NAN; sym.len_val()];
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| factorize(sn, &sched, &mut ws, vals, &mut l)).unwrap();
        l
    }

    /// An order that is not a postorder of its elimination tree (two interleaved paths in the
    /// identity order, as faer's AMD sometimes leaves it): the schedule refuses it, and
    /// `ordering::postorder` of it gives one the schedule takes, with faer's factor.
    #[test]
    fn an_order_that_is_no_postorder_is_refused_and_postordering_repairs_it() {
        use faer::perm::PermRef;
        let n = 9;
        let pattern: Vec<Vec<usize>> = (0..n).map(|c| if c + 2 < n { vec![c, c + 2] } else { vec![c] }).collect();
        let col_ptr: Vec<usize> = std::iter::once(0)
            .chain(pattern.iter().scan(0, |k, c| {
                *k += c.len();
                Some(*k)
            }))
            .collect();
        let row_idx: Vec<usize> = pattern.concat();
        let vals: Vec<f64> =
            pattern.iter().flat_map(|c| c.iter().map(|&r| if r == c[0] { 4.0 } else { -1.0 })).collect();
        let a = SymbolicSparseColMat::<usize>::new_checked(n, n, col_ptr.clone(), None, row_idx.clone());
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let with = |fwd: &[usize]| {
            let inv = crate::linear::ordering::inverse(fwd);
            let custom = SymmetricOrdering::Custom(PermRef::new_checked(fwd, &inv, n));
            factorize_symbolic_cholesky(a.as_ref(), Side::Lower, custom, params).unwrap()
        };
        let identity: Vec<usize> = (0..n).collect();
        let sym = with(&identity);
        assert_eq!(
            Schedule::new(supernodal(&sym), sym.perm(), &col_ptr, &row_idx).err(),
            Some(ScheduleError::NotPostordered)
        );
        let post = crate::linear::ordering::postorder(n, &col_ptr, &row_idx, &identity);
        assert_eq!(post, [1, 3, 5, 7, 0, 2, 4, 6, 8]);
        let sym = with(&post);
        let mut reference = vec![0.0; sym.len_val()];
        let mut mem = MemBuffer::new(sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let values = SparseColMatRef::new(a.as_ref(), &vals);
        let seq = (Side::Lower, LltRegularization::default(), Par::Seq);
        sym.factorize_numeric_llt::<f64>(
            &mut reference,
            values,
            seq.0,
            seq.1,
            seq.2,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
        let l = ours(&sym, &col_ptr, &row_idx, &vals, 1);
        let diff = l.iter().zip(&reference).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= 1e-14, "max |L - L_faer| = {diff:e}");
    }

    #[test]
    fn factor_matches_faers_sequential_factorization() {
        let (n, cp, ri, vals) = system("bumpy_10k");
        let (a, sym) = analyse(n, &cp, &ri);
        let mut reference = vec![0.0; sym.len_val()];
        let mut mem = MemBuffer::new(sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        sym.factorize_numeric_llt::<f64>(
            &mut reference,
            SparseColMatRef::new(a.as_ref(), &vals),
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
        let l = ours(&sym, &cp, &ri, &vals, 2);
        let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = l.iter().zip(&reference).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= 1e-12 * scale, "max |L - L_faer| = {diff:e} (max |L| = {scale:e})");
        assert!(supernodal(&sym).n_supernodes() > 100, "the test needs a real tree");
    }

    #[test]
    fn factor_is_deterministic_and_the_same_for_every_thread_count() {
        let (n, cp, ri, vals) = system("bumpy_10k");
        let (_, sym) = analyse(n, &cp, &ri);
        let one = ours(&sym, &cp, &ri, &vals, 1);
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        for threads in [2, 3, 4] {
            let l = ours(&sym, &cp, &ri, &vals, threads);
            for _ in 0..3 {
                assert!(same(&l, &ours(&sym, &cp, &ri, &vals, threads)), "{threads} threads, twice");
            }
            assert!(same(&l, &one), "{threads} threads against 1");
        }
    }

    #[test]
    fn an_indefinite_matrix_reports_its_pivot() {
        let (n, cp, ri, mut vals) = system("bumpy_1k");
        let (_, sym) = analyse(n, &cp, &ri);
        let sn = supernodal(&sym);
        let sched = Schedule::new(sn, sym.perm(), &cp, &ri).unwrap();
        // Make column 17's diagonal negative: some pivot fails.
        let d17 = (cp[17]..cp[18]).find(|&p| ri[p] == 17).unwrap();
        vals[d17] = -1.0;
        let mut l = vec![0.0; sym.len_val()];
        let mut ws = Workspace::default();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let r = pool.install(|| factorize(sn, &sched, &mut ws, &vals, &mut l));
        assert!(matches!(r, Err(LltError::NonPositivePivot { .. })), "{r:?}");
    }

    #[test]
    fn the_schedule_is_a_postordered_forest_covering_every_supernode() {
        let (n, cp, ri, _) = system("bumpy_1k");
        let (_, sym) = analyse(n, &cp, &ri);
        let sn = supernodal(&sym);
        let sched = Schedule::new(sn, sym.perm(), &cp, &ri).unwrap();
        let ns = sn.n_supernodes();
        let covered: usize = sched.roots.iter().map(|&r| r - sched.first[r] + 1).sum();
        assert_eq!(covered, ns);
        for s in 0..ns {
            for &c in sched.children(s) {
                assert!(c < s && sched.first[s] <= sched.first[c]);
            }
            for &d in sched.updates(s) {
                assert!(d < s && d >= sched.first[s], "an update of {s} from outside its subtree: {d}");
            }
        }
        assert_eq!(sched.a_to_l.len(), ri.len());
    }
}
