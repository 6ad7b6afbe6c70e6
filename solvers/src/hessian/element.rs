//! One element's Hessian in the complex view, `H = A M^T K M` (complex-view paper, Eq. 2,
//! Appendix A): the evaluated element, its `K` (Eq. 3) and `K`'s analytic eigensystem.

use crate::energy::Modifiers;
use crate::local::{LocalOp, Wirtinger};
use nalgebra::{Matrix4, Matrix6, Vector4, Vector6};

/// One element evaluated at the current map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementState {
    /// `f_z` as a real 2-vector `[re, im]`.
    pub fz: [f64; 2],
    /// `f_zbar` as a real 2-vector `[re, im]`.
    pub fzb: [f64; 2],
    /// The energy's modifiers at `(x, y)`.
    pub m: Modifiers,
}

impl ElementState {
    /// The state with the Wirtinger derivatives of `w` and the modifiers `m`.
    pub fn new(w: Wirtinger, m: Modifiers) -> Self {
        ElementState { fz: w.fz, fzb: w.fzb, m }
    }
    /// The Wirtinger derivatives the state was evaluated at.
    #[inline]
    pub fn wirtinger(&self) -> Wirtinger {
        Wirtinger { fz: self.fz, fzb: self.fzb }
    }
    /// `x = |f_z|^2` ([`Wirtinger::x`]).
    #[inline]
    pub fn x(&self) -> f64 {
        self.wirtinger().x()
    }
    /// `y = |f_zbar|^2` ([`Wirtinger::y`]).
    #[inline]
    pub fn y(&self) -> f64 {
        self.wirtinger().y()
    }
}

/// `K` of Eq. 3 (per unit area).
pub fn k_matrix(s: &ElementState) -> Matrix4<f64> {
    let [f0, f1] = s.fz;
    let [g0, g1] = s.fzb;
    let m = &s.m;
    let (a1, a2) = (2.0 * m.a1, 2.0 * m.a2);
    let (b1, b2, b3) = (4.0 * m.b1, 4.0 * m.b2, 4.0 * m.b3);
    // Written out entry by entry: the block-view version was miscompiled in release
    // builds (wrong off-diagonal entries with rustc 1.95 / nalgebra 0.35), see the test
    // `k_matrix_matches_its_definition`.
    #[rustfmt::skip]
    let k = Matrix4::new(
        a1 + b1 * f0 * f0, b1 * f0 * f1,      b3 * f0 * g0,      b3 * f0 * g1,
        b1 * f1 * f0,      a1 + b1 * f1 * f1, b3 * f1 * g0,      b3 * f1 * g1,
        b3 * g0 * f0,      b3 * g0 * f1,      a2 + b2 * g0 * g0, b2 * g0 * g1,
        b3 * g1 * f0,      b3 * g1 * f1,      b2 * g1 * g0,      a2 + b2 * g1 * g1,
    );
    k
}

/// Analytic eigensystem of `K` (Chen and Weber 2017, restated in Appendix B): the
/// eigenvalues `2 a1` (direction `i f_z`), `2 a2` (direction `i f_zbar`) and the two
/// eigenvalues of the 2x2 "radial" block in the basis `(f_z/|f_z|, f_zbar/|f_zbar|)`.
/// Eigenvectors are orthonormal. When `f_zbar = 0` its direction is arbitrary and any unit
/// vector gives a valid eigenbasis.
#[derive(Clone, Copy, Debug)]
pub struct KEigen {
    /// Eigenvalues: `2 a1`, `2 a2`, then the two of the radial block.
    pub values: [f64; 4],
    /// Orthonormal eigenvectors, in the order of `values`.
    pub vectors: [Vector4<f64>; 4],
}

/// The analytic eigensystem of `K` at the element state `s`.
pub fn k_eigen(s: &ElementState) -> KEigen {
    let (x, y) = (s.x(), s.y());
    let (nf, ng) = (x.sqrt(), y.sqrt());
    let ef = if nf > 0.0 { [s.fz[0] / nf, s.fz[1] / nf] } else { [1.0, 0.0] };
    let eg = if ng > 0.0 { [s.fzb[0] / ng, s.fzb[1] / ng] } else { [1.0, 0.0] };
    let m = &s.m;
    let p = 2.0 * m.a1 + 4.0 * m.b1 * x;
    let r = 2.0 * m.a2 + 4.0 * m.b2 * y;
    let q = 4.0 * m.b3 * nf * ng;
    // 2x2 symmetric eigen by rotation angle: robust when q ~ 0.
    let theta = 0.5 * (2.0 * q).atan2(p - r);
    let (sn, cs) = theta.sin_cos();
    let l3 = p * cs * cs + 2.0 * q * sn * cs + r * sn * sn;
    let l4 = p * sn * sn - 2.0 * q * sn * cs + r * cs * cs;
    KEigen {
        values: [2.0 * m.a1, 2.0 * m.a2, l3, l4],
        vectors: [
            Vector4::new(-ef[1], ef[0], 0.0, 0.0),
            Vector4::new(0.0, 0.0, -eg[1], eg[0]),
            Vector4::new(cs * ef[0], cs * ef[1], sn * eg[0], sn * eg[1]),
            Vector4::new(-sn * ef[0], -sn * ef[1], cs * eg[0], cs * eg[1]),
        ],
    }
}

/// Relative threshold under which an eigenvalue counts as zero rather than negative, so
/// round-off at exactly-singular states (e.g. `2 a1 = 0` at an isometry) is not counted.
pub const NEG_EIG_RTOL: f64 = 1e-12;

/// The eigenvalues of `K` in the order of [`k_eigen`], without its eigenvectors: the radial
/// block `[[p, q], [q, r]]` from its mean and half-gap, no trigonometry. Every evaluation
/// counts the inertia of every element, so this is on the per-iteration path; the
/// values agree with [`k_eigen`]'s to round-off (`k_eigenvalues_match_the_eigensystem`).
#[inline]
pub fn k_eigenvalues(s: &ElementState) -> [f64; 4] {
    let (x, y) = (s.x(), s.y());
    let m = &s.m;
    let p = 2.0 * m.a1 + 4.0 * m.b1 * x;
    let r = 2.0 * m.a2 + 4.0 * m.b2 * y;
    let q = 4.0 * m.b3 * (x * y).sqrt();
    let mean = 0.5 * (p + r);
    let half_gap = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    [2.0 * m.a1, 2.0 * m.a2, mean + half_gap, mean - half_gap]
}

/// Number of negative eigenvalues of the unmodified element Hessian. `M` has full row rank
/// for a non-degenerate triangle, so by Sylvester's law of inertia this equals the count of
/// `K` (verified in the reference notes, section 1.4).
#[inline]
pub fn count_negative(s: &ElementState) -> usize {
    let values = k_eigenvalues(s);
    let scale = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    values.iter().filter(|&&v| v < -NEG_EIG_RTOL * scale).count()
}

/// Gradient of `A psi` with respect to the 6 local dofs (Appendix A):
/// `A M^T (2 a1 f_z, 2 a2 f_zbar)`.
pub fn element_gradient(op: &LocalOp, s: &ElementState) -> Vector6<f64> {
    let w =
        Vector4::new(2.0 * s.m.a1 * s.fz[0], 2.0 * s.m.a1 * s.fz[1], 2.0 * s.m.a2 * s.fzb[0], 2.0 * s.m.a2 * s.fzb[1]);
    op.mt_times(w) * op.area
}

/// `A M^T K M` for any 4x4 `K`.
pub fn triple_product(op: &LocalOp, k: &Matrix4<f64>) -> Matrix6<f64> {
    let m = op.m();
    (m.transpose() * k * m) * op.area
}

/// The unmodified element Hessian `A M^T K M`.
pub fn element_hessian(op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
    triple_product(op, &k_matrix(s))
}
