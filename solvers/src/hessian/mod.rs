//! Per-element Hessians in the complex view and their PSD modifications.
//!
//! The Hessian of one element is `H = A M^T K M` (complex-view paper, Eq. 2 and
//! Appendix A) with the 4x4 matrix of Eq. 3,
//! `K = [[2 a1 I + 4 b1 f f^T, 4 b3 f g^T], [4 b3 g f^T, 2 a2 I + 4 b2 g g^T]]`,
//! `f = f_z`, `g = f_zbar` as real 2-vectors. A [`SystemBlock`] strategy turns an
//! evaluated element into the 6x6 block of the Newton system; strategies are peers
//! sharing the rest of the pipeline.

pub mod akvf;
pub mod cm;
pub mod fp;
pub mod kp;
pub mod none;
pub mod pn;
pub mod slim;

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
    /// `x = |f_z|^2`.
    #[inline]
    pub fn x(&self) -> f64 {
        self.fz[0] * self.fz[0] + self.fz[1] * self.fz[1]
    }
    /// `y = |f_zbar|^2`.
    #[inline]
    pub fn y(&self) -> f64 {
        self.fzb[0] * self.fzb[0] + self.fzb[1] * self.fzb[1]
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

/// A strategy that turns an evaluated element into its block of the Newton system.
/// Adding a Hessian modification is one implementation of this trait plus one registry line.
pub trait SystemBlock: Send + Sync {
    /// The 6x6 block (including the source-area weight) in local dofs `(u1, v1, u2, v2, u3, v3)`.
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64>;

    /// A multiple of the identity added to the assembled matrix (SLIM's proximal term).
    fn diagonal_shift(&self) -> f64 {
        0.0
    }

    /// Whether the driver retries a failed factorization with larger Tikhonov shifts (a
    /// safety net of the strategies whose blocks are PSD, where a failure is round-off or a
    /// null space; the shift used is recorded per iteration). A strategy without it stops at
    /// its first failed factorization with `linear_solve_failed`.
    fn retries_failed_factorization(&self) -> bool {
        true
    }

    /// Names of the strategy's per-iteration counters ([`SystemBlock::counters`]), which the
    /// driver appends to each row as solver-specific columns (`IterationRecord::extra`).
    fn counter_names(&self) -> &'static [&'static str] {
        &[]
    }

    /// The counters of the system built from `states` (one value per
    /// [`SystemBlock::counter_names`] entry, in order), e.g. SLIM's clamped weights.
    fn counters(&self, _states: &[ElementState]) -> Vec<f64> {
        Vec::new()
    }

    /// The trust-region rule of an adaptive filter (`pn-trust-region`, `fp-trust-region-6x6`):
    /// the driver then builds each system with [`pn::TrustRegion::system`] in the mode the rule
    /// chose from the last step's model fit, and writes the mode and the fit as the strategy's
    /// counters.
    fn trust_region(&self) -> Option<pn::TrustRegion> {
        None
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, random_xy, Lcg};
    use crate::energy::{EnergyKind, Sd};

    /// A random orientation-preserving element state of energy `e` on a random triangle.
    pub fn random_element(rng: &mut Lcg, e: &EnergyKind) -> (LocalOp, [[f64; 2]; 3], ElementState) {
        loop {
            let z = [
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
            ];
            let Some(op) = LocalOp::from_planar(z) else { continue };
            if op.area < 0.05 {
                continue;
            }
            let y = [
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
                [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
            ];
            let w = op.wirtinger(y);
            let (x, yy) = (w.x(), w.y());
            if !(x > 1.2 * yy) || !(0.05..=20.0).contains(&x) {
                continue;
            }
            let Some(m) = e.modifiers(x, yy) else { continue };
            return (op, y, ElementState::new(w, m));
        }
    }

    fn element_energy(op: &LocalOp, e: &EnergyKind, y: [[f64; 2]; 3]) -> f64 {
        let w = op.wirtinger(y);
        op.area * e.value(w.x(), w.y())
    }

    fn element_grad(op: &LocalOp, e: &EnergyKind, y: [[f64; 2]; 3]) -> Vector6<f64> {
        let w = op.wirtinger(y);
        element_gradient(op, &ElementState::new(w, e.modifiers(w.x(), w.y()).unwrap()))
    }

    fn perturb(y: [[f64; 2]; 3], i: usize, h: f64) -> [[f64; 2]; 3] {
        let mut z = y;
        z[i / 2][i % 2] += h;
        z
    }

    #[test]
    fn gradient_and_hessian_match_central_differences() {
        let mut rng = Lcg(11);
        for e in all_energies() {
            for _ in 0..50 {
                let (op, y, s) = random_element(&mut rng, &e);
                let g = element_gradient(&op, &s);
                let h = element_hessian(&op, &s);
                let step = 1e-6;
                for i in 0..6 {
                    let fd = (element_energy(&op, &e, perturb(y, i, step))
                        - element_energy(&op, &e, perturb(y, i, -step)))
                        / (2.0 * step);
                    assert!((fd - g[i]).abs() <= 1e-5 * g.amax().max(1.0), "{e:?} grad {i}: {fd} vs {}", g[i]);
                    let fdg = (element_grad(&op, &e, perturb(y, i, step))
                        - element_grad(&op, &e, perturb(y, i, -step)))
                        / (2.0 * step);
                    for j in 0..6 {
                        assert!(
                            (fdg[j] - h[(j, i)]).abs() <= 1e-5 * h.amax().max(1.0),
                            "{e:?} hess ({j},{i}): {} vs {}",
                            fdg[j],
                            h[(j, i)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn k_matrix_matches_its_definition() {
        // Eq. 3 built from outer products of embedded 4-vectors, a code path independent of
        // `k_matrix` (whose first version was miscompiled in release builds).
        let mut rng = Lcg(3);
        for e in all_energies() {
            for _ in 0..100 {
                let (_, _, s) = random_element(&mut rng, &e);
                let f = Vector4::new(s.fz[0], s.fz[1], 0.0, 0.0);
                let g = Vector4::new(0.0, 0.0, s.fzb[0], s.fzb[1]);
                let p = Matrix4::from_diagonal(&Vector4::new(1.0, 1.0, 0.0, 0.0));
                let q = Matrix4::identity() - p;
                let k = p * (2.0 * s.m.a1)
                    + q * (2.0 * s.m.a2)
                    + f * f.transpose() * (4.0 * s.m.b1)
                    + g * g.transpose() * (4.0 * s.m.b2)
                    + (f * g.transpose() + g * f.transpose()) * (4.0 * s.m.b3);
                assert!((k - k_matrix(&s)).norm() <= 1e-13 * k.norm(), "{e:?}");
            }
        }
    }

    #[test]
    fn analytic_eigensystem_reconstructs_k() {
        let mut rng = Lcg(5);
        for e in all_energies() {
            for _ in 0..200 {
                let (_, _, s) = random_element(&mut rng, &e);
                let k = k_matrix(&s);
                let eig = k_eigen(&s);
                let mut r = Matrix4::zeros();
                for i in 0..4 {
                    r += eig.vectors[i] * eig.vectors[i].transpose() * eig.values[i];
                    assert!((k * eig.vectors[i] - eig.vectors[i] * eig.values[i]).norm() <= 1e-10 * k.norm());
                }
                assert!((r - k).norm() <= 1e-11 * k.norm(), "{e:?}");
            }
        }
    }

    /// The trig-free eigenvalues equal the eigensystem's, also where `f_zbar = 0` (an
    /// isometry or a similarity) and where the radial block is diagonal.
    #[test]
    fn k_eigenvalues_match_the_eigensystem() {
        let mut rng = Lcg(29);
        for e in all_energies() {
            let mut states: Vec<ElementState> = (0..300).map(|_| random_element(&mut rng, &e).2).collect();
            for x in [0.5, 1.0, 2.0] {
                if let Some(m) = e.modifiers(x, 0.0) {
                    states.push(ElementState { fz: [x.sqrt(), 0.0], fzb: [0.0, 0.0], m });
                }
            }
            for s in states {
                let (fast, eig) = (k_eigenvalues(&s), k_eigen(&s).values);
                let scale = eig.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                for (a, b) in fast.iter().zip(&eig) {
                    assert!((a - b).abs() <= 1e-13 * scale, "{e:?}: {fast:?} vs {eig:?}");
                }
            }
        }
    }

    #[test]
    fn inertia_of_h_equals_inertia_of_k() {
        let mut rng = Lcg(9);
        for e in all_energies() {
            for _ in 0..200 {
                let (op, _, s) = random_element(&mut rng, &e);
                let h = element_hessian(&op, &s);
                let ev = h.symmetric_eigenvalues();
                let scale = ev.amax();
                // H has a 2-dimensional null space (translations); count clear negatives.
                let neg_h = ev.iter().filter(|&&v| v < -1e-9 * scale).count();
                assert_eq!(neg_h, count_negative(&s), "{e:?}");
            }
        }
    }

    #[test]
    fn sd_negative_iff_alpha1_negative() {
        // Notes 1.5: for SD at most one negative eigenvalue, exactly when a1 < 0, i.e. when
        // sigma1^2 - sigma1 sigma2 + sigma2^2 > (sigma1 sigma2)^3.
        let mut rng = Lcg(21);
        for _ in 0..2000 {
            let (x, y) = random_xy(&mut rng);
            let m = EnergyKind::Sd(Sd).modifiers(x, y).unwrap();
            let s = ElementState { fz: [x.sqrt(), 0.0], fzb: [0.0, y.sqrt()], m };
            let (s1, s2) = (x.sqrt() + y.sqrt(), x.sqrt() - y.sqrt());
            let closed = s1 * s1 - s1 * s2 + s2 * s2 > (s1 * s2).powi(3);
            assert_eq!(count_negative(&s), usize::from(closed));
        }
    }
}
