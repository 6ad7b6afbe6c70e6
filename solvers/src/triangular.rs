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
//! register. AEM-CG's preconditioner solves at 200k: 58-69 ms per iteration against 76-90 ms
//! with faer's sequential solve and 90-104 ms with its parallel one (README, issue 21).
//!
//! One thread, a fixed order: the result is the same bits on every call and for any pool
//! (it differs from faer's in the rounding of the sums: `tests::equals_faers_solve`).

use crate::supernodal::{s_pattern, s_range};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

/// Solve `P A P^T = L L^T` for the `x.len() / n` columns of `x` (column-major, `n` rows
/// each) in place: `x <- A^-1 x`. `l` are the factor's values in `sym`'s layout, `perm`
/// the fill-reducing permutation (`None`: the identity), `work` scratch kept by the caller.
pub fn solve_in_place(
    sym: &SymbolicSupernodalCholesky<usize>,
    perm: Option<PermRef<'_, usize>>,
    l: &[f64],
    x: &mut [f64],
    work: &mut Vec<f64>,
) {
    let n = sym.nrows();
    if n == 0 {
        return;
    }
    let k = x.len() / n;
    match k {
        1 => solve_k::<1>(sym, perm, l, x, work),
        2 => solve_k::<2>(sym, perm, l, x, work),
        _ => {
            for col in x.chunks_exact_mut(n) {
                solve_k::<1>(sym, perm, l, col, work);
            }
        }
    }
}

/// [`solve_in_place`] for exactly `K` columns.
fn solve_k<const K: usize>(
    sym: &SymbolicSupernodalCholesky<usize>,
    perm: Option<PermRef<'_, usize>>,
    l: &[f64],
    x: &mut [f64],
    work: &mut Vec<f64>,
) {
    let n = sym.nrows();
    let fwd = perm.map(|p| p.arrays().0);
    let old = |i: usize| fwd.map_or(i, |f| f[i]);
    let max_pat = sym.nnz_per_super().iter().copied().max().unwrap_or(0);
    // `w[i]`: the K right-hand sides of row i of the permuted system; `t`: a supernode's
    // pattern rows, gathered (backward) or accumulated before one scatter (forward).
    work.clear();
    work.resize((n + max_pat) * K, 0.0);
    let (w, t) = as_rows::<K>(work).split_at_mut(n);
    for (i, wi) in w.iter_mut().enumerate() {
        let o = old(i);
        *wi = std::array::from_fn(|c| x[c * n + o]);
    }
    let ns = sym.n_supernodes();
    // Forward: L y = P b. Per supernode the diagonal block by columns, then its rows below
    // as one product `t = L_below y_s` and one scatter `y[pattern] -= t`.
    for s in 0..ns {
        let Supernode { b, e, pat, block } = Supernode::of(sym, l, s);
        let (ncols, nrows) = (e - b, e - b + pat.len());
        let t = &mut t[..pat.len()];
        t.fill([0.0; K]);
        let ws = &mut w[b..e];
        for (j, col) in block.chunks_exact(nrows).enumerate() {
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
        for (&r, ti) in pat.iter().zip(t.iter()) {
            for c in 0..K {
                w[r][c] -= ti[c];
            }
        }
    }
    // Backward: L^T z = y, in reverse. Per supernode one gather of its pattern rows, then
    // its columns from the last: `z_j = (y_j - L[rows > j, j]^T z[rows > j]) / L_jj`.
    for s in (0..ns).rev() {
        let Supernode { b, e, pat, block } = Supernode::of(sym, l, s);
        let (ncols, nrows) = (e - b, e - b + pat.len());
        let t = &mut t[..pat.len()];
        for (ti, &r) in t.iter_mut().zip(pat) {
            *ti = w[r];
        }
        let ws = &mut w[b..e];
        for (j, col) in block.chunks_exact(nrows).enumerate().rev() {
            let mut acc = dot::<K>(&col[ncols..], t);
            let within = dot::<K>(&col[j + 1..ncols], &ws[j + 1..]);
            for c in 0..K {
                acc[c] += within[c];
            }
            let d = col[j];
            ws[j] = std::array::from_fn(|c| (ws[j][c] - acc[c]) / d);
        }
    }
    for (i, wi) in w.iter().enumerate() {
        let o = old(i);
        for c in 0..K {
            x[c * n + o] = wi[c];
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
    use crate::supernodal::tests::{analyse, supernodal, system};
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
        let mut work = Vec::new();
        for k in [1, 2, 3] {
            let b = rhs(n * k, k);
            let mut want = b.clone();
            let rhs_mat = MatMut::from_column_major_slice_mut(&mut want, n, k);
            LltRef::new(&sym, &l).solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, MemStack::new(&mut mem));
            let mut got = b.clone();
            solve_in_place(supernodal(&sym), sym.perm(), &l, &mut got, &mut work);
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = got.iter().zip(&want).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(diff <= 1e-12 * scale, "{k} columns: max diff {diff:e} (max |x| {scale:e})");
            let mut again = b.clone();
            solve_in_place(supernodal(&sym), sym.perm(), &l, &mut again, &mut work);
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
        solve_in_place(sn, None, &l, &mut x, &mut Vec::new());
        assert_eq!(x, b);
        solve_in_place(sn, sym.perm(), &l, &mut x, &mut Vec::new());
        assert_eq!(x, b);
        let mut empty: Vec<f64> = Vec::new();
        solve_in_place(sn, None, &l, &mut empty, &mut Vec::new());
    }
}
