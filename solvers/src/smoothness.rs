//! The energy smoothness term of the complex-view paper (Section 4.3, Appendix B):
//! `E_ij = w l_ij (psi_i - psi_j)^2` for every pair of faces `T_i, T_j` sharing an interior
//! edge of rest length `l_ij`, `psi` the per-face energy density.
//!
//! `E_ij` depends on the map only through `v = (f_iz, f_izbar, f_jz, f_jzbar)` (four vectors
//! of R^2), via `p_k = |v_k|^2`. With `rho_k = dE/dp_k` and `ups_kl = d2E/dp_k dp_l`:
//! gradient `sum_k 2 rho_k v_k`, Hessian `K8 = blockdiag(2 rho_k I_2) + 4 [ups_kl v_k v_l^T]`
//! (the 8x8 analogue of K, Eq. 3), and the Hessian in the 8 dofs of the edge's 4 vertices is
//! `M^T K8 M` with `M` the two faces' Wirtinger operators.
//!
//! Analytic projection (Section 4.3): the directions orthogonal to each `v_k` have eigenvalue
//! `2 rho_k` (clamped at 0); along the `v_k` the Hessian is `4 Lambda U' Lambda` with
//! `Lambda = diag|v_k|` and `U' = ups + diag(rho_k / (2 p_k))`, which splits into a
//! block-diagonal part (one 2x2 block per face, projected in closed form) plus the PSD
//! outer product `2 c g g^T`. The numeric variant clamps the eigenvalues of the 8x8 Hessian.

use crate::hessian::ElementState;
use crate::local::LocalOp;
use nalgebra::{Matrix2, Matrix4, SMatrix, SVector, SymmetricEigen, Vector2, Vector4};

/// An 8x8 matrix of an edge pair: its operator `M` or a Hessian block.
pub type Matrix8 = SMatrix<f64, 8, 8>;
/// A vector in the 8 dofs (u, v of each vertex in [`EdgePair::verts`] order) of an edge pair.
pub type Vector8 = SVector<f64, 8>;

/// How the edge Hessians are made PSD.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Projection {
    /// Section 4.3 / Appendix B in closed form.
    #[default]
    Analytic,
    /// Eigen-decomposition of every 8x8 block, negative eigenvalues clamped to 0.
    Numeric,
    /// The unmodified 8x8 Hessian (plain Newton on the smoothness term; may be indefinite).
    Exact,
}

/// Two faces sharing an interior edge.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgePair {
    /// The two faces, lower index first.
    pub faces: [usize; 2],
    /// The edge's vertices `a, b` then the opposite vertices of `faces[0]` and `faces[1]`.
    pub verts: [usize; 4],
    /// For each face, the position in `verts` of its local vertices 0, 1, 2.
    pub local: [[usize; 3]; 2],
    /// Rest length of the common edge.
    pub len: f64,
}

/// The smoothness term of a problem: weight `w`, projection, and per interior edge its pair
/// and operator `M`.
#[derive(Clone, Debug)]
pub struct Smoothness {
    /// The weight `w`.
    pub weight: f64,
    /// How the edge blocks are made PSD for the Newton system.
    pub projection: Projection,
    /// The interior edges, sorted by their vertices.
    pub pairs: Vec<EdgePair>,
    /// Per pair, the operator `M` from its 8 dofs to `(f_iz, f_izbar, f_jz, f_jzbar)` ([`edge_operator`]).
    pub ops: Vec<Matrix8>,
}

impl Smoothness {
    /// The term of weight `weight` over the interior edges of the rest mesh (`faces`, `positions`),
    /// with the faces' operators `face_ops`.
    pub fn new(
        weight: f64,
        projection: Projection,
        faces: &[[usize; 3]],
        positions: &[[f64; 3]],
        face_ops: &[LocalOp],
    ) -> Smoothness {
        let pairs = edge_pairs(faces, positions);
        let ops = pairs.iter().map(|p| edge_operator([&face_ops[p.faces[0]], &face_ops[p.faces[1]]], p)).collect();
        Smoothness { weight, projection, pairs, ops }
    }

    /// The 4-vertex lists of the edge blocks (for the sparsity pattern).
    pub fn edge_vertices(&self) -> Vec<[usize; 4]> {
        self.pairs.iter().map(|p| p.verts).collect()
    }

    /// `c = w l` of edge `e`.
    #[inline]
    pub fn coefficient(&self, e: usize) -> f64 {
        self.weight * self.pairs[e].len
    }
}

/// The interior edges of a manifold mesh (edges with exactly two faces), in edge order.
pub fn edge_pairs(faces: &[[usize; 3]], positions: &[[f64; 3]]) -> Vec<EdgePair> {
    let mut half: Vec<(usize, usize, usize)> = Vec::with_capacity(3 * faces.len());
    for (t, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            half.push((a.min(b), a.max(b), t));
        }
    }
    half.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < half.len() {
        let mut j = i;
        while j < half.len() && (half[j].0, half[j].1) == (half[i].0, half[i].1) {
            j += 1;
        }
        if j - i == 2 {
            let (a, b) = (half[i].0, half[i].1);
            let (ti, tj) = (half[i].2, half[i + 1].2);
            let opp = |t: usize| faces[t].iter().copied().find(|&v| v != a && v != b).unwrap_or(a);
            let verts = [a, b, opp(ti), opp(tj)];
            let pos = |v: usize| verts.iter().position(|&w| w == v).unwrap_or(0);
            let local = [faces[ti].map(pos), faces[tj].map(pos)];
            let (p, q) = (positions[a], positions[b]);
            let len = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            out.push(EdgePair { faces: [ti, tj], verts, local, len });
        }
        i = j;
    }
    out
}

/// `M` (8x8): rows `(f_iz, f_izbar, f_jz, f_jzbar)` as real pairs, columns the edge dofs.
pub fn edge_operator(ops: [&LocalOp; 2], pair: &EdgePair) -> Matrix8 {
    let mut m = Matrix8::zeros();
    for (s, op) in ops.iter().enumerate() {
        let mf = op.m();
        for (k, &slot) in pair.local[s].iter().enumerate() {
            for r in 0..4 {
                m[(4 * s + r, 2 * slot)] = mf[(r, 2 * k)];
                m[(4 * s + r, 2 * slot + 1)] = mf[(r, 2 * k + 1)];
            }
        }
    }
    m
}

/// The edge term's derivatives in `p = (x_i, y_i, x_j, y_j)` for weight `c = w l`.
struct Derivs {
    delta: f64,
    /// `(a_i1, a_i2, -a_j1, -a_j2)`: `d(psi_i - psi_j)/dp`.
    g: Vector4<f64>,
    rho: Vector4<f64>,
    ups: Matrix4<f64>,
    /// `v_k` as rows.
    v: [Vector2<f64>; 4],
}

fn derivs(c: f64, si: &ElementState, sj: &ElementState) -> Derivs {
    let delta = si.m.psi - sj.m.psi;
    let g = Vector4::new(si.m.a1, si.m.a2, -sj.m.a1, -sj.m.a2);
    let rho = g * (2.0 * c * delta);
    let mut b = Matrix4::zeros();
    b[(0, 0)] = si.m.b1;
    b[(1, 1)] = si.m.b2;
    b[(0, 1)] = si.m.b3;
    b[(1, 0)] = si.m.b3;
    b[(2, 2)] = -sj.m.b1;
    b[(3, 3)] = -sj.m.b2;
    b[(2, 3)] = -sj.m.b3;
    b[(3, 2)] = -sj.m.b3;
    let ups = (g * g.transpose() + b * delta) * (2.0 * c);
    let v = [si.fz, si.fzb, sj.fz, sj.fzb].map(|a| Vector2::new(a[0], a[1]));
    Derivs { delta, g, rho, ups, v }
}

/// `E_ij = c (psi_i - psi_j)^2` with `c = w l`.
pub fn value(c: f64, si: &ElementState, sj: &ElementState) -> f64 {
    c * (si.m.psi - sj.m.psi).powi(2)
}

/// Gradient in the 8 edge dofs: `M^T (2 rho_k v_k)_k`.
pub fn gradient(c: f64, si: &ElementState, sj: &ElementState, m: &Matrix8) -> Vector8 {
    let d = derivs(c, si, sj);
    let mut w = Vector8::zeros();
    for k in 0..4 {
        w[2 * k] = 2.0 * d.rho[k] * d.v[k][0];
        w[2 * k + 1] = 2.0 * d.rho[k] * d.v[k][1];
    }
    m.transpose() * w
}

/// `k[2a.., 2b..] += blk`, entry by entry (nalgebra's `fixed_view_mut` miscompiled in release
/// builds for `k_matrix`; see `hessian::k_matrix`).
fn add_block(k: &mut Matrix8, a: usize, b: usize, blk: &Matrix2<f64>) {
    for r in 0..2 {
        for c in 0..2 {
            k[(2 * a + r, 2 * b + c)] += blk[(r, c)];
        }
    }
}

/// The unmodified `K8`.
pub fn k8(c: f64, si: &ElementState, sj: &ElementState) -> Matrix8 {
    let d = derivs(c, si, sj);
    let mut k = Matrix8::zeros();
    for a in 0..4 {
        for b in 0..4 {
            let blk = d.v[a] * d.v[b].transpose() * (4.0 * d.ups[(a, b)])
                + if a == b { Matrix2::identity() * (2.0 * d.rho[a]) } else { Matrix2::zeros() };
            add_block(&mut k, a, b, &blk);
        }
    }
    k
}

/// Closest PSD matrix to a symmetric 2x2 in closed form.
fn psd2(a: f64, b: f64, d: f64) -> Matrix2<f64> {
    let (m, h) = (0.5 * (a + d), 0.5 * (a - d));
    let r = h.hypot(b);
    let (l1, l2) = (m + r, m - r);
    if l2 >= 0.0 {
        return Matrix2::new(a, b, b, d);
    }
    if l1 <= 0.0 {
        return Matrix2::zeros();
    }
    // eigenvector of l1: (b, l1 - a) or (l1 - d, b), whichever is better conditioned
    let e = if (l1 - a).abs() > (l1 - d).abs() { Vector2::new(b, l1 - a) } else { Vector2::new(l1 - d, b) };
    let n2 = e.norm_squared();
    if !(n2 > 0.0) {
        return Matrix2::new(a.max(0.0), 0.0, 0.0, d.max(0.0));
    }
    e * e.transpose() * (l1 / n2)
}

/// `K8` projected analytically (Section 4.3, Appendix B).
pub fn k8_analytic(c: f64, si: &ElementState, sj: &ElementState) -> Matrix8 {
    let d = derivs(c, si, sj);
    let p: [f64; 4] = d.v.map(|v| v.norm_squared());
    let tiny = 1e-24 * (1.0 + p.iter().fold(0.0f64, |a, &b| a.max(b)));
    let active: [bool; 4] = p.map(|x| x > tiny);
    let mut k = Matrix8::zeros();
    // Directions orthogonal to v_k (all of R^2 when v_k vanishes): eigenvalue 2 rho_k.
    for a in 0..4 {
        let lam = (2.0 * d.rho[a]).max(0.0);
        let perp = if active[a] {
            let n = d.v[a] / p[a].sqrt();
            Matrix2::identity() - n * n.transpose()
        } else {
            Matrix2::identity()
        };
        add_block(&mut k, a, a, &(perp * lam));
    }
    // Along the v_k: 4 Lambda (D+ + 2c g g^T) Lambda with D the per-face 2x2 blocks of U'.
    let mut t = (d.g * d.g.transpose()) * (2.0 * c);
    for face in 0..2 {
        let (i, j) = (2 * face, 2 * face + 1);
        let sign = if face == 0 { 1.0 } else { -1.0 };
        let s = if face == 0 { si } else { sj };
        let dd = |k: usize, b: f64| 2.0 * c * d.delta * sign * b + d.rho[k] / (2.0 * p[k]);
        match (active[i], active[j]) {
            (true, true) => {
                let q = psd2(dd(i, s.m.b1), 2.0 * c * d.delta * sign * s.m.b3, dd(j, s.m.b2));
                t[(i, i)] += q[(0, 0)];
                t[(i, j)] += q[(0, 1)];
                t[(j, i)] += q[(1, 0)];
                t[(j, j)] += q[(1, 1)];
            }
            (true, false) => t[(i, i)] += dd(i, s.m.b1).max(0.0),
            (false, true) => t[(j, j)] += dd(j, s.m.b2).max(0.0),
            (false, false) => {}
        }
    }
    for a in (0..4).filter(|&a| active[a]) {
        for b in (0..4).filter(|&b| active[b]) {
            add_block(&mut k, a, b, &(d.v[a] * d.v[b].transpose() * (4.0 * t[(a, b)])));
        }
    }
    k
}

/// The edge's block of the Newton system in its 8 dofs.
pub fn block(c: f64, si: &ElementState, sj: &ElementState, m: &Matrix8, projection: Projection) -> Matrix8 {
    match projection {
        Projection::Analytic => m.transpose() * k8_analytic(c, si, sj) * m,
        Projection::Exact => m.transpose() * k8(c, si, sj) * m,
        Projection::Numeric => {
            let h = m.transpose() * k8(c, si, sj) * m;
            let e = SymmetricEigen::new(h);
            let lam = e.eigenvalues.map(|l| l.max(0.0));
            e.eigenvectors * Matrix8::from_diagonal(&lam) * e.eigenvectors.transpose()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Barap, Bconf, EnergyKind, Nh, Sd};
    use crate::hessian::ElementState;

    fn lcg(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// Two triangles sharing the edge (0, 1): the pair, its ops, a map of the 4 vertices.
    fn setup(r: &mut impl FnMut() -> f64) -> (EdgePair, [LocalOp; 2], [f64; 8]) {
        let (pair, ops, x, _) = setup_with_rest(r);
        (pair, ops, x)
    }

    /// As [`setup`], plus the rest positions of the pair's 4 vertices (in `verts` order).
    fn setup_with_rest(r: &mut impl FnMut() -> f64) -> (EdgePair, [LocalOp; 2], [f64; 8], [[f64; 2]; 4]) {
        let faces = [[0, 1, 2], [1, 0, 3]];
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.1 * r(), 0.0], [0.4 + 0.2 * r(), 0.9, 0.0], [0.6 + 0.2 * r(), -0.8, 0.0]];
        let pair = edge_pairs(&faces, &pos).remove(0);
        let op = |f: [usize; 3]| LocalOp::from_planar(f.map(|v| [pos[v][0], pos[v][1]])).unwrap();
        let ops = [op(faces[pair.faces[0]]), op(faces[pair.faces[1]])];
        // a moderately distorted orientation-preserving map of the 4 vertices
        let mut x = [0.0; 8];
        for (slot, &v) in pair.verts.iter().enumerate() {
            x[2 * slot] = 1.3 * pos[v][0] + 0.2 * pos[v][1] + 0.05 * r();
            x[2 * slot + 1] = -0.1 * pos[v][0] + 0.8 * pos[v][1] + 0.05 * r();
        }
        let rest = pair.verts.map(|v| [pos[v][0], pos[v][1]]);
        (pair, ops, x, rest)
    }

    fn states(e: &EnergyKind, pair: &EdgePair, ops: &[LocalOp; 2], x: &[f64; 8]) -> Option<[ElementState; 2]> {
        let st = |s: usize| {
            let y = pair.local[s].map(|slot| [x[2 * slot], x[2 * slot + 1]]);
            let w = ops[s].wirtinger(y);
            e.modifiers(w.x(), w.y()).map(|m| ElementState::new(w, m))
        };
        Some([st(0)?, st(1)?])
    }

    const ENERGIES: [EnergyKind; 4] = [
        EnergyKind::Sd(Sd),
        EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 }),
        EnergyKind::Bconf(Bconf { k: 0.1 }),
        EnergyKind::Barap(Barap { k: 0.1 }),
    ];

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let mut r = lcg(3);
        for e in ENERGIES {
            for _ in 0..5 {
                let (pair, ops, x) = setup(&mut r);
                let c = 0.7;
                let [si, sj] = states(&e, &pair, &ops, &x).unwrap();
                let m = edge_operator([&ops[0], &ops[1]], &pair);
                let g = gradient(c, &si, &sj, &m);
                let h = m.transpose() * k8(c, &si, &sj) * m;
                let f = |y: &[f64; 8]| {
                    let [a, b] = states(&e, &pair, &ops, y).unwrap();
                    value(c, &a, &b)
                };
                let grad_at = |y: &[f64; 8]| {
                    let [a, b] = states(&e, &pair, &ops, y).unwrap();
                    gradient(c, &a, &b, &m)
                };
                let step = 1e-6;
                for i in 0..8 {
                    let (mut xp, mut xm) = (x, x);
                    xp[i] += step;
                    xm[i] -= step;
                    let fd = (f(&xp) - f(&xm)) / (2.0 * step);
                    assert!((fd - g[i]).abs() <= 1e-6 * (1.0 + g[i].abs()), "{e:?} grad {i}: {fd} vs {}", g[i]);
                    let col = (grad_at(&xp) - grad_at(&xm)) / (2.0 * step);
                    for j in 0..8 {
                        assert!(
                            (col[j] - h[(j, i)]).abs() <= 1e-5 * (1.0 + h[(j, i)].abs()),
                            "{e:?} hess ({j},{i}): {} vs {}",
                            col[j],
                            h[(j, i)]
                        );
                    }
                }
            }
        }
    }

    fn min_eig(h: &Matrix8) -> (f64, f64) {
        let ev = SymmetricEigen::new(*h).eigenvalues;
        (ev.min(), ev.amax())
    }

    #[test]
    fn projections_are_psd_and_agree_where_the_analytic_one_is_exact() {
        let mut r = lcg(9);
        for e in ENERGIES {
            let mut checked = 0;
            for _ in 0..200 {
                let (pair, ops, mut x) = setup(&mut r);
                for v in x.iter_mut() {
                    *v *= 1.0 + 0.3 * r();
                }
                let Some([si, sj]) = states(&e, &pair, &ops, &x) else { continue };
                let c = 0.5;
                let m = edge_operator([&ops[0], &ops[1]], &pair);
                for (label, h) in [
                    ("analytic", block(c, &si, &sj, &m, Projection::Analytic)),
                    ("numeric", block(c, &si, &sj, &m, Projection::Numeric)),
                ] {
                    let (lo, scale) = min_eig(&h);
                    assert!(lo >= -1e-9 * scale.max(1e-12), "{e:?} {label}: {lo} (scale {scale})");
                    assert!((h - h.transpose()).amax() <= 1e-12 * scale.max(1e-12));
                }
                checked += 1;
            }
            assert!(checked > 150, "{e:?}: {checked}");
        }
    }

    #[test]
    fn with_equal_densities_the_hessian_is_psd_and_both_projections_keep_it() {
        // The same affine map on both faces: psi_i = psi_j, so rho = 0 and K8 = 8c (g.v)(g.v)^T
        // is PSD; the analytic projection is exact there (Section 4.3) and the numeric one too.
        let mut r = lcg(11);
        for e in ENERGIES {
            for _ in 0..20 {
                let (pair, ops, _, rest) = setup_with_rest(&mut r);
                let (a, b, cc, d) = (1.0 + 0.3 * r(), 0.3 * r(), 0.3 * r(), 0.9 + 0.2 * r());
                let mut x = [0.0; 8];
                for (slot, &[px, py]) in rest.iter().enumerate() {
                    x[2 * slot] = a * px + b * py;
                    x[2 * slot + 1] = cc * px + d * py;
                }
                let Some([si, sj]) = states(&e, &pair, &ops, &x) else { continue };
                assert!((si.m.psi - sj.m.psi).abs() <= 1e-9 * si.m.psi.abs().max(1.0), "{e:?}");
                let c = 0.5;
                let m = edge_operator([&ops[0], &ops[1]], &pair);
                let exact = m.transpose() * k8(c, &si, &sj) * m;
                let (lo, scale) = min_eig(&exact);
                assert!(lo >= -1e-9 * scale.max(1e-12), "{e:?}: {lo}");
                let analytic = block(c, &si, &sj, &m, Projection::Analytic);
                let numeric = block(c, &si, &sj, &m, Projection::Numeric);
                assert!((analytic - exact).amax() <= 1e-8 * scale.max(1e-12), "{e:?}");
                assert!((numeric - exact).amax() <= 1e-8 * scale.max(1e-12), "{e:?}");
            }
        }
    }

    #[test]
    fn edge_pairs_are_the_interior_edges() {
        let faces = [[0, 1, 2], [0, 2, 3], [0, 3, 4]];
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.5, 0.0]];
        let pairs = edge_pairs(&faces, &pos);
        assert_eq!(pairs.len(), 2);
        assert_eq!(pairs[0].verts, [0, 2, 1, 3]);
        assert_eq!(pairs[0].faces, [0, 1]);
        assert!((pairs[0].len - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(pairs[0].local, [[0, 2, 1], [0, 1, 3]]);
    }
}
