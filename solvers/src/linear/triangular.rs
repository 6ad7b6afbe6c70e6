//! The triangular solves `L L^T x = b` with a supernodal factor in faer's layout (the one
//! `supernodal::factorize` writes), for a few right-hand sides at once.
//!
//! faer's solve calls its dense kernels per supernode (a triangular solve on the diagonal
//! block, a matrix product below it), whose dispatch costs as much as the work on the small
//! supernodes of a one-coordinate Laplacian, and on several threads forks per supernode.
//! Here each supernode is plain loops over its contiguous values: forward, the diagonal
//! block column by column and the rows below as one product into a buffer scattered once
//! (`x[rows] -= L[rows, s] x_s`); backward, one gather of those rows and a dot product per
//! column in four partial sums (one running sum would wait on the adder's latency); the
//! right-hand sides interleaved so that one value serves all of them while it is in a
//! register (docs/src/results/parallel-factorization.md measures it against faer's solves).
//!
//! Large factors are solved on the calling pool's threads: disjoint subtrees of the
//! elimination tree run as tasks and the supernodes above them on one thread, with every
//! row receiving the same operations in the same order as in the sequential solve (`Tasks`),
//! so the result is the same bits on every call and for any pool (it differs from faer's in
//! the rounding of the sums: `tests::equals_faers_solve`).

use super::supernodal::{s_pattern, s_range, Schedule};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use rayon::prelude::*;

/// Factors with fewer values than this are solved on one thread: below it a task costs more
/// than it saves.
const PARALLEL_MIN_VALUES: usize = 1 << 19;

/// A parallel task is a subtree with at most `1 / (TASKS_PER_THREAD * threads)` of the
/// factor's values: small enough to balance the threads, large enough that the supernodes
/// above all tasks (solved on one thread) stay a small share. Other counts per thread
/// measured the same within the noise: the threads share the memory bandwidth.
const TASKS_PER_THREAD: usize = 2;

/// Scratch of the solves, kept by the caller between calls.
#[derive(Debug, Default)]
pub struct SolveWork {
    /// The interleaved right-hand sides, then a supernode's pattern rows (`t`).
    rows: Vec<f64>,
    /// The rows above all tasks, copied for the tasks' backward pass to read.
    snapshot: Vec<f64>,
    tasks: Vec<TaskWork>,
}

/// One task's pattern rows and the forward updates it owes the rows above it.
#[derive(Debug, Default)]
struct TaskWork {
    t: Vec<f64>,
    deferred: Vec<f64>,
}

/// Solve `P A P^T = L L^T` for the `x.len() / n` columns of `x` (column-major, `n` rows
/// each) in place: `x <- A^-1 x`. `l` are the factor's values in `sym`'s layout, `perm`
/// the fill-reducing permutation (`None`: the identity), `sched` the factorization's
/// schedule (its tree lets large factors be solved on the calling pool's threads), `work`
/// scratch kept by the caller. The result is the same bits for any pool.
pub fn solve_in_place(
    sym: &SymbolicSupernodalCholesky<usize>,
    perm: Option<PermRef<'_, usize>>,
    sched: Option<&Schedule>,
    l: &[f64],
    x: &mut [f64],
    work: &mut SolveWork,
) {
    let tasks = sched.map_or_else(Vec::new, |sc| split(sym, sc, rayon::current_num_threads(), PARALLEL_MIN_VALUES));
    let tasks = sched.filter(|_| !tasks.is_empty()).map(|sc| (sc, &tasks[..]));
    Solve { sym, perm, l, tasks }.run(x, work);
}

/// Roots of disjoint subtrees (increasing) to solve as parallel tasks on `threads` threads,
/// each with at most `1 / (TASKS_PER_THREAD * threads)` of the values; none when the factor
/// has fewer than `min_values` values or there is one thread. Subtrees far smaller than
/// that stay with the supernodes above the tasks.
fn split(sym: &SymbolicSupernodalCholesky<usize>, sched: &Schedule, threads: usize, min_values: usize) -> Vec<usize> {
    let val = sym.col_ptr_for_val();
    let total = val[sym.n_supernodes()];
    if threads < 2 || total < min_values.max(1) {
        return Vec::new();
    }
    let size = |s: usize| val[s + 1] - val[sched.first(s)];
    let target = total / (TASKS_PER_THREAD * threads);
    let mut tasks = Vec::new();
    let mut stack = sched.roots().to_vec();
    while let Some(s) = stack.pop() {
        if size(s) > target {
            stack.extend_from_slice(sched.children(s));
        } else if size(s) >= target / 64 {
            tasks.push(s);
        }
    }
    tasks.sort_unstable();
    tasks
}

/// One solve: the factor (`l` in `sym`'s layout, `perm` its permutation) and, when the
/// solve runs on several threads, the schedule and the roots of the subtrees run as tasks.
struct Solve<'a> {
    sym: &'a SymbolicSupernodalCholesky<usize>,
    perm: Option<PermRef<'a, usize>>,
    l: &'a [f64],
    tasks: Option<(&'a Schedule, &'a [usize])>,
}

impl Solve<'_> {
    /// All the columns of `x`: two together, one, or more one by one.
    fn run(&self, x: &mut [f64], work: &mut SolveWork) {
        let n = self.sym.nrows();
        if n == 0 {
            return;
        }
        match x.len() / n {
            1 => self.columns::<1>(x, work),
            2 => self.columns::<2>(x, work),
            _ => x.chunks_exact_mut(n).for_each(|col| self.columns::<1>(col, work)),
        }
    }

    /// The solve for exactly `K` columns.
    fn columns<const K: usize>(&self, x: &mut [f64], work: &mut SolveWork) {
        let Solve { sym, perm, l, tasks } = *self;
        let n = sym.nrows();
        let fwd = perm.map(|p| p.arrays().0);
        let old = |i: usize| fwd.map_or(i, |f| f[i]);
        let max_pat = sym.nnz_per_super().iter().copied().max().unwrap_or(0);
        // `w[i]`: the K right-hand sides of row i of the permuted system; `t`: a supernode's
        // pattern rows, gathered (backward) or accumulated before one scatter (forward).
        work.rows.clear();
        work.rows.resize((n + max_pat) * K, 0.0);
        let (w, t) = as_rows::<K>(&mut work.rows).split_at_mut(n);
        for (i, wi) in w.iter_mut().enumerate() {
            let o = old(i);
            *wi = std::array::from_fn(|c| x[c * n + o]);
        }
        match tasks {
            Some((sched, roots)) => {
                let tw = &mut work.tasks;
                tw.resize_with(roots.len(), TaskWork::default);
                Tasks { sym, sched, l, roots, max_pat }.solve::<K>(w, t, tw, &mut work.snapshot);
            }
            None => {
                for s in 0..sym.n_supernodes() {
                    forward_one(&Supernode::of(sym, l, s), w, t);
                }
                for s in (0..sym.n_supernodes()).rev() {
                    backward_one(&Supernode::of(sym, l, s), w, t);
                }
            }
        }
        for (i, wi) in w.iter().enumerate() {
            let o = old(i);
            for c in 0..K {
                x[c * n + o] = wi[c];
            }
        }
    }
}

/// Forward step of one supernode on the whole right-hand side: `y[pattern] -= L_below y_s`.
fn forward_one<const K: usize>(sn: &Supernode, w: &mut [[f64; K]], t: &mut [[f64; K]]) {
    let t = &mut t[..sn.pat.len()];
    forward_block(sn, &mut w[sn.b..sn.e], t);
    for (&r, ti) in sn.pat.iter().zip(t.iter()) {
        for c in 0..K {
            w[r][c] -= ti[c];
        }
    }
}

/// Backward step of one supernode on the whole right-hand side.
fn backward_one<const K: usize>(sn: &Supernode, w: &mut [[f64; K]], t: &mut [[f64; K]]) {
    let t = &mut t[..sn.pat.len()];
    for (ti, &r) in t.iter_mut().zip(sn.pat) {
        *ti = w[r];
    }
    backward_block(sn, &mut w[sn.b..sn.e], t);
}

/// Forward (`L y = b`) within a supernode: its diagonal block column by column on its own
/// rows `ws`, then its rows below as one product `t = L_below y_s` (the caller scatters it).
#[inline]
fn forward_block<const K: usize>(sn: &Supernode, ws: &mut [[f64; K]], t: &mut [[f64; K]]) {
    let (ncols, nrows) = (sn.e - sn.b, sn.e - sn.b + sn.pat.len());
    t.fill([0.0; K]);
    for (j, col) in sn.block.chunks_exact(nrows).enumerate() {
        let d = col[j];
        let xj: [f64; K] = std::array::from_fn(|c| ws[j][c] / d);
        ws[j] = xj;
        for (wi, &v) in ws[j + 1..].iter_mut().zip(&col[j + 1..ncols]) {
            for c in 0..K {
                wi[c] -= v * xj[c];
            }
        }
        for (ti, &v) in t.iter_mut().zip(&col[ncols..]) {
            for c in 0..K {
                ti[c] += v * xj[c];
            }
        }
    }
}

/// Backward (`L^T z = y`) within a supernode, its pattern rows gathered in `t`: its columns
/// from the last, `z_j = (y_j - L[rows > j, j]^T z[rows > j]) / L_jj`.
#[inline]
fn backward_block<const K: usize>(sn: &Supernode, ws: &mut [[f64; K]], t: &[[f64; K]]) {
    let (ncols, nrows) = (sn.e - sn.b, sn.e - sn.b + sn.pat.len());
    for (j, col) in sn.block.chunks_exact(nrows).enumerate().rev() {
        let mut acc = dot::<K>(&col[ncols..], t);
        let within = dot::<K>(&col[j + 1..ncols], &ws[j + 1..]);
        for c in 0..K {
            acc[c] += within[c];
        }
        let d = col[j];
        ws[j] = std::array::from_fn(|c| (ws[j][c] - acc[c]) / d);
    }
}

/// The solve with disjoint subtrees of the elimination tree as parallel tasks, the same
/// bits as the sequential one. A subtree's rows are updated only by its own supernodes, so
/// the tasks run their forward passes at once; the updates they owe the rows outside them
/// (all of them rows of the task root's ancestors, which are in no task) are kept in order
/// and applied when the sequential walk over the remaining supernodes reaches the subtree's
/// place, so every row receives the same subtractions in the same order as in the
/// sequential solve. Backward,
/// the supernodes above the tasks go first, then the tasks at once, reading those rows.
struct Tasks<'a> {
    sym: &'a SymbolicSupernodalCholesky<usize>,
    sched: &'a Schedule,
    l: &'a [f64],
    /// The subtrees' roots, increasing.
    roots: &'a [usize],
    max_pat: usize,
}

impl Tasks<'_> {
    /// The rows (columns of the permuted system) of the subtree of `root`.
    fn span(&self, root: usize) -> (usize, usize) {
        (s_range(self.sym, self.sched.first(root)).0, s_range(self.sym, root).1)
    }

    /// `w` cut into the tasks' row ranges, in order.
    fn parts<'w, T>(&self, mut w: &'w mut [T]) -> Vec<&'w mut [T]> {
        let mut parts = Vec::with_capacity(self.roots.len());
        let mut offset = 0;
        for &r in self.roots {
            let (b, e) = self.span(r);
            let (mine, rest) = std::mem::take(&mut w)[b - offset..].split_at_mut(e - b);
            parts.push(mine);
            w = rest;
            offset = e;
        }
        parts
    }

    /// The outside rows (at or past `end`, the ancestors) of supernode `s`'s pattern start here.
    fn outside(&self, s: usize, end: usize) -> usize {
        s_pattern(self.sym, s).partition_point(|&r| r < end)
    }

    fn solve<const K: usize>(
        &self,
        w: &mut [[f64; K]],
        t: &mut [[f64; K]],
        task_work: &mut [TaskWork],
        snapshot: &mut Vec<f64>,
    ) {
        let (sym, l, ns) = (self.sym, self.l, self.sym.n_supernodes());
        self.parts(w)
            .into_par_iter()
            .zip(self.roots)
            .zip(&mut *task_work)
            .with_max_len(1)
            .for_each(|((ws, &r), tw)| self.forward_task::<K>(r, ws, tw));
        // The supernodes above the tasks in order; each task's deferred updates at its place.
        let mut s = 0;
        let mut next = 0;
        while s < ns {
            match self.roots.get(next) {
                Some(&r) if self.sched.first(r) == s => {
                    let end = self.span(r).1;
                    let rows = (s..=r).flat_map(|d| &s_pattern(sym, d)[self.outside(d, end)..]);
                    for (&row, v) in rows.zip(task_work[next].deferred.as_chunks::<K>().0) {
                        for c in 0..K {
                            w[row][c] -= v[c];
                        }
                    }
                    s = r + 1;
                    next += 1;
                }
                _ => {
                    forward_one(&Supernode::of(sym, l, s), w, t);
                    s += 1;
                }
            }
        }
        // Backward: the supernodes above the tasks, in reverse.
        let mut s = ns;
        let mut next = self.roots.len();
        while s > 0 {
            match next.checked_sub(1).map(|i| self.roots[i]) {
                Some(r) if r + 1 == s => {
                    s = self.sched.first(r);
                    next -= 1;
                }
                _ => {
                    s -= 1;
                    backward_one(&Supernode::of(sym, l, s), w, t);
                }
            }
        }
        // Their rows, final now, for the tasks to read while each writes its own.
        snapshot.resize(w.len() * K, 0.0);
        let snap = as_rows::<K>(snapshot);
        let mut prev = 0;
        for &r in self.roots {
            let (b, e) = self.span(r);
            snap[prev..b].copy_from_slice(&w[prev..b]);
            prev = e;
        }
        snap[prev..].copy_from_slice(&w[prev..]);
        let snap: &[[f64; K]] = snap;
        self.parts(w)
            .into_par_iter()
            .zip(self.roots)
            .zip(&mut *task_work)
            .with_max_len(1)
            .for_each(|((ws, &r), tw)| self.backward_task::<K>(r, ws, tw, snap));
    }

    /// Forward over the subtree of `root`, whose rows are `ws`; the updates of the rows
    /// outside it go to `tw.deferred`, in order.
    fn forward_task<const K: usize>(&self, root: usize, ws: &mut [[f64; K]], tw: &mut TaskWork) {
        let (base, end) = self.span(root);
        let TaskWork { t, deferred } = tw;
        t.resize(self.max_pat * K, 0.0);
        let t = as_rows::<K>(t);
        deferred.clear();
        for s in self.sched.first(root)..=root {
            let sn = Supernode::of(self.sym, self.l, s);
            let t = &mut t[..sn.pat.len()];
            forward_block(&sn, &mut ws[sn.b - base..sn.e - base], t);
            let inside = self.outside(s, end);
            for (&r, ti) in sn.pat[..inside].iter().zip(t.iter()) {
                for c in 0..K {
                    ws[r - base][c] -= ti[c];
                }
            }
            t[inside..].iter().for_each(|ti| deferred.extend_from_slice(ti));
        }
    }

    /// Backward over the subtree of `root`, whose rows are `ws`; the rows above it are read
    /// from `snap`.
    fn backward_task<const K: usize>(&self, root: usize, ws: &mut [[f64; K]], tw: &mut TaskWork, snap: &[[f64; K]]) {
        let (base, end) = self.span(root);
        tw.t.resize(self.max_pat * K, 0.0);
        let t = as_rows::<K>(&mut tw.t);
        for s in (self.sched.first(root)..=root).rev() {
            let sn = Supernode::of(self.sym, self.l, s);
            let t = &mut t[..sn.pat.len()];
            let (t_in, t_out) = t.split_at_mut(self.outside(s, end));
            let (p_in, p_out) = sn.pat.split_at(t_in.len());
            t_in.iter_mut().zip(p_in).for_each(|(ti, &r)| *ti = ws[r - base]);
            t_out.iter_mut().zip(p_out).for_each(|(ti, &r)| *ti = snap[r]);
            backward_block(&sn, &mut ws[sn.b - base..sn.e - base], t);
        }
    }
}

/// One supernode of the factor: its columns `b..e`, its rows below them and its values
/// (column-major, `e - b + pat.len()` rows).
struct Supernode<'a> {
    b: usize,
    e: usize,
    pat: &'a [usize],
    block: &'a [f64],
}

impl<'a> Supernode<'a> {
    fn of(sym: &'a SymbolicSupernodalCholesky<usize>, l: &'a [f64], s: usize) -> Supernode<'a> {
        let (b, e) = s_range(sym, s);
        let pat = s_pattern(sym, s);
        let block = &l[sym.col_ptr_for_val()[s]..][..(e - b + pat.len()) * (e - b)];
        Supernode { b, e, pat, block }
    }
}

/// `sum_i v_i x_i` for each of the K columns of the rows `x`, in LANES interleaved partial
/// sums (a single running sum is one long chain of dependent additions: the backward pass's
/// dot products would wait on the adder's latency, not on memory), added up in a fixed order.
#[inline]
fn dot<const K: usize>(v: &[f64], x: &[[f64; K]]) -> [f64; K] {
    const LANES: usize = 4;
    let mut part = [[0.0; K]; LANES];
    let (vc, vr) = v.as_chunks::<LANES>();
    let (xc, xr) = x.as_chunks::<LANES>();
    for (vs, xs) in vc.iter().zip(xc) {
        for lane in 0..LANES {
            let v = vs[lane];
            for c in 0..K {
                part[lane][c] += v * xs[lane][c];
            }
        }
    }
    for (&v, xi) in vr.iter().zip(xr) {
        for c in 0..K {
            part[0][c] += v * xi[c];
        }
    }
    std::array::from_fn(|c| (part[0][c] + part[1][c]) + (part[2][c] + part[3][c]))
}

/// `v` (of a multiple of `K` entries) as rows of `K`.
fn as_rows<const K: usize>(v: &mut [f64]) -> &mut [[f64; K]] {
    let (rows, rest) = v.as_chunks_mut::<K>();
    debug_assert!(rest.is_empty());
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::supernodal::tests::{analyse, supernodal, system};
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::llt::factor::LltRegularization;
    use faer::sparse::linalg::cholesky::LltRef;
    use faer::sparse::SparseColMatRef;
    use faer::{Conj, MatMut, Par, Side};

    fn rhs(len: usize, seed: usize) -> Vec<f64> {
        (0..len).map(|i| ((i * 37 + seed) % 101) as f64 / 101.0 - 0.5).collect()
    }

    /// The same solution as faer's solve with the same factor, to round-off, for one, two
    /// (together) and three (one by one) right-hand sides; the same bits on a second call.
    #[test]
    fn equals_faers_solve() {
        let (n, cp, ri, vals) = system("bumpy_10k");
        let (a, sym) = analyse(n, &cp, &ri);
        assert!(sym.perm().is_some() && supernodal(&sym).n_supernodes() > 100, "the test needs a real tree");
        let req = sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
        let mut mem = MemBuffer::new(req.or(sym.solve_in_place_scratch::<f64>(3, Par::Seq)));
        let mut l = vec![0.0; sym.len_val()];
        let a = SparseColMatRef::new(a.as_ref(), &vals);
        let reg = LltRegularization::default();
        sym.factorize_numeric_llt(&mut l, a, Side::Lower, reg, Par::Seq, MemStack::new(&mut mem), Default::default())
            .unwrap();
        let mut work = SolveWork::default();
        for k in [1, 2, 3] {
            let b = rhs(n * k, k);
            let mut want = b.clone();
            let rhs_mat = MatMut::from_column_major_slice_mut(&mut want, n, k);
            LltRef::new(&sym, &l).solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, MemStack::new(&mut mem));
            let mut got = b.clone();
            solve_in_place(supernodal(&sym), sym.perm(), None, &l, &mut got, &mut work);
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = got.iter().zip(&want).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(diff <= 1e-12 * scale, "{k} columns: max diff {diff:e} (max |x| {scale:e})");
            let mut again = b.clone();
            solve_in_place(supernodal(&sym), sym.perm(), None, &l, &mut again, &mut work);
            assert!(again.iter().zip(&got).all(|(x, y)| x.to_bits() == y.to_bits()), "{k} columns, twice");
        }
    }

    /// Without a permutation the solve is plain `L L^T`: an identity factor leaves `b`.
    #[test]
    fn an_empty_right_hand_side_and_an_identity_factor() {
        let (n, cp, ri, _) = system("bumpy_1k");
        let (_, sym) = analyse(n, &cp, &ri);
        let sn = supernodal(&sym);
        let mut l = vec![0.0; sym.len_val()];
        for s in 0..sn.n_supernodes() {
            let (b, e) = (sn.supernode_begin()[s], sn.supernode_end()[s]);
            let nrows = e - b + sn.nnz_per_super()[s];
            for j in 0..e - b {
                l[sn.col_ptr_for_val()[s] + j * nrows + j] = 1.0;
            }
        }
        let b = rhs(2 * n, 3);
        let mut x = b.clone();
        solve_in_place(sn, None, None, &l, &mut x, &mut SolveWork::default());
        assert_eq!(x, b);
        solve_in_place(sn, sym.perm(), None, &l, &mut x, &mut SolveWork::default());
        assert_eq!(x, b);
        let mut empty: Vec<f64> = Vec::new();
        solve_in_place(sn, None, None, &l, &mut empty, &mut SolveWork::default());
    }

    /// Subtrees solved as parallel tasks give the sequential solve's bits, for every split
    /// (2 to 4 threads' worth of tasks, each in a pool of that many threads, twice with the
    /// same scratch) and other sets of subtrees, for one, two and three right-hand sides.
    #[test]
    fn parallel_tasks_give_the_sequential_bits() {
        let (n, cp, ri, vals) = system("bumpy_10k");
        let (_, sym) = analyse(n, &cp, &ri);
        let sn = supernodal(&sym);
        let sched = Schedule::new(sn, sym.perm(), &cp, &ri).unwrap();
        let mut ws = crate::linear::supernodal::Workspace::default();
        let mut l = vec![0.0; sym.len_val()];
        crate::linear::supernodal::factorize(sn, &sched, &mut ws, &vals, &mut l).unwrap();
        for k in [1, 2, 3] {
            let b = rhs(n * k, 7 + k);
            let mut want = b.clone();
            Solve { sym: sn, perm: sym.perm(), l: &l, tasks: None }.run(&mut want, &mut SolveWork::default());
            // Beyond `split`'s choices, any disjoint subtrees: every leaf (adjacent tasks,
            // supernodes above them in between), and every other subtree of a split (whole
            // subtrees left to the sequential walk between tasks).
            let leaves: Vec<usize> = (0..sn.n_supernodes()).filter(|&s| sched.children(s).is_empty()).collect();
            let every_other: Vec<usize> = split(sn, &sched, 4, 0).into_iter().step_by(2).collect();
            for threads in 2..=4 {
                let tasks = split(sn, &sched, threads, 0);
                assert!(tasks.len() >= threads, "{threads} threads: {} tasks", tasks.len());
                let in_tasks: usize = tasks.iter().map(|&r| r + 1 - sched.first(r)).sum();
                assert!(in_tasks < sn.n_supernodes(), "some supernodes are above the tasks");
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut work = SolveWork::default();
                for (round, tasks) in [&tasks, &tasks, &leaves, &every_other].into_iter().enumerate() {
                    let mut got = b.clone();
                    let solve = Solve { sym: sn, perm: sym.perm(), l: &l, tasks: Some((&sched, &tasks[..])) };
                    pool.install(|| solve.run(&mut got, &mut work));
                    let same = got.iter().zip(&want).all(|(x, y)| x.to_bits() == y.to_bits());
                    assert!(same, "{k} columns, {threads} threads, round {round}");
                }
            }
        }
    }

    /// One thread or a small factor: no tasks.
    #[test]
    fn no_tasks_on_one_thread_or_below_the_size() {
        let (n, cp, ri, _) = system("bumpy_10k");
        let (_, sym) = analyse(n, &cp, &ri);
        let sn = supernodal(&sym);
        let sched = Schedule::new(sn, sym.perm(), &cp, &ri).unwrap();
        assert!(split(sn, &sched, 1, 0).is_empty());
        assert!(split(sn, &sched, 2, sym.len_val() + 1).is_empty());
        assert!(!split(sn, &sched, 2, sym.len_val()).is_empty());
    }
}
