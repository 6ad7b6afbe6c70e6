//! FP-Newton: the optimal (Frobenius-nearest) PSD projection of each element Hessian,
//! numerically (complex-view paper, Section 4 and Table 5).
//!
//! * [`Fp6`] eigen-decomposes the 6x6 `H` and clamps negative eigenvalues at 0.
//! * [`Fp4`] uses the reduced RQ factorization `M = R Q` (`R` lower triangular, `Q` with
//!   orthonormal rows): `H = Q^T (R^T K R) Q`, so clamping the 4x4 `R^T K R` projects `H`
//!   exactly. The rows of `D` and `conj(D)` are already orthogonal with equal norm, so
//!   only the last two rows of `R` differ from a scaled identity ("only two rows change").
//! * [`Fp6Abs`] replaces the 6x6 `H`'s eigenvalues by their absolute values instead (the abs
//!   filter of Chen et al. 2024 as they apply it, to the element Hessian; see `pn`).

use super::element::{element_hessian, k_matrix, ElementState};
use super::system_block::SystemBlock;
use crate::local::LocalOp;
use nalgebra::{Matrix4, Matrix4x6, Matrix6};

/// Filter the eigenvalues of a symmetric matrix by `$f` when any is negative.
macro_rules! filter_psd {
    ($m:expr, $f:expr) => {{
        let m = $m;
        let se = m.symmetric_eigen();
        if se.eigenvalues.iter().all(|&v| v >= 0.0) {
            m
        } else {
            let lambda = se.eigenvalues.map($f);
            &se.eigenvectors * nalgebra::Matrix::from_diagonal(&lambda) * se.eigenvectors.transpose()
        }
    }};
}

/// Clamp the eigenvalues of a symmetric matrix at 0 (no epsilon floor, as the reference).
macro_rules! clamp_psd {
    ($m:expr) => {
        filter_psd!($m, |v: f64| v.max(0.0))
    };
}

/// `fp-newton-6x6`: the 6x6 element Hessian with its negative eigenvalues clamped at 0.
#[derive(Clone, Copy, Debug, Default)]
pub struct Fp6;

impl SystemBlock for Fp6 {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        clamp_psd!(element_hessian(op, s))
    }
}

/// `pn-abs`'s check: the abs filter on the 6x6 element Hessian, numerically.
#[derive(Clone, Copy, Debug, Default)]
pub struct Fp6Abs;

impl SystemBlock for Fp6Abs {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        filter_psd!(element_hessian(op, s), f64::abs)
    }
}

/// The lower-triangular factor `L` with `M M^T = L L^T` (so `M = L Q`, `Q Q^T = I`), in
/// closed form: the first two rows of `M` are orthogonal with norm `nu`, hence `L[..2] =
/// nu I` and only rows 2 and 3 need Gram-Schmidt. `None` for a rank-deficient `M`.
pub fn rq_factor(m: &Matrix4x6<f64>) -> Option<Matrix4<f64>> {
    let g = m * m.transpose();
    let nu = g[(0, 0)].sqrt();
    let l20 = g[(2, 0)] / nu;
    let l21 = g[(2, 1)] / nu;
    let l30 = g[(3, 0)] / nu;
    let l31 = g[(3, 1)] / nu;
    let l22 = (g[(2, 2)] - l20 * l20 - l21 * l21).sqrt();
    let l32 = (g[(3, 2)] - l30 * l20 - l31 * l21) / l22;
    let l33 = (g[(3, 3)] - l30 * l30 - l31 * l31 - l32 * l32).sqrt();
    let l = Matrix4::new(nu, 0.0, 0.0, 0.0, 0.0, nu, 0.0, 0.0, l20, l21, l22, 0.0, l30, l31, l32, l33);
    l.iter().all(|v| v.is_finite()).then_some(l).filter(|_| l22 > 0.0 && l33 > 0.0)
}

/// `fp-newton-4x4`: the same projection, computed on the reduced 4x4 matrix `L^T K L`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Fp4;

impl SystemBlock for Fp4 {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        let m = op.m();
        let Some(l) = rq_factor(&m) else {
            // A rank-deficient M only arises for degenerate triangles, which validation
            // rejects; fall back to the 6x6 projection rather than produce garbage.
            return Fp6.block(op, s);
        };
        let k = k_matrix(s);
        let p = clamp_psd!(l.transpose() * k * l);
        // Q = L^-1 M; H+ = A Q^T P+ Q
        let q = l.solve_lower_triangular(&m).unwrap_or_else(|| unreachable!("L has a positive diagonal"));
        (q.transpose() * p * q) * op.area
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, Lcg};
    use crate::hessian::tests::random_element;

    #[test]
    fn rq_factor_reproduces_m_with_orthonormal_q() {
        let mut rng = Lcg(51);
        for _ in 0..200 {
            let (op, _, _) = random_element(&mut rng, &crate::energy::EnergyKind::Sd(crate::energy::Sd));
            let m = op.m();
            let l = rq_factor(&m).unwrap();
            let q = l.solve_lower_triangular(&m).unwrap();
            assert!((q * q.transpose() - Matrix4::identity()).norm() < 1e-10);
            assert!((l * q - m).norm() <= 1e-12 * m.norm());
            // only rows 2 and 3 differ from nu I
            assert_eq!(l[(0, 1)], 0.0);
            assert_eq!(l[(0, 0)], l[(1, 1)]);
        }
    }

    #[test]
    fn fp4_equals_fp6_and_is_psd() {
        let mut rng = Lcg(53);
        for e in all_energies() {
            for _ in 0..300 {
                let (op, _, s) = random_element(&mut rng, &e);
                let a = Fp4.block(&op, &s);
                let b = Fp6.block(&op, &s);
                assert!((a - b).norm() <= 1e-10 * b.norm().max(1e-300), "{e:?}: {}", (a - b).norm() / b.norm());
                let ev = a.symmetric_eigenvalues();
                assert!(ev.min() >= -1e-10 * ev.amax(), "{e:?}");
            }
        }
    }

    /// The abs filter through the reduced 4x4 matrix (`|H| = Q^T |L^T K L| Q`, as FP4 clamps)
    /// equals the 6x6 one; it is PSD, keeps a PSD `H`, and keeps `|H|`'s eigenvalue magnitudes.
    #[test]
    fn fp_abs_through_the_reduced_matrix_equals_the_6x6_filter() {
        let mut rng = Lcg(59);
        for e in all_energies() {
            let mut flipped = 0;
            for _ in 0..300 {
                let (op, _, s) = random_element(&mut rng, &e);
                let m = op.m();
                let l = rq_factor(&m).unwrap();
                let q = l.solve_lower_triangular(&m).unwrap();
                let p = filter_psd!(l.transpose() * k_matrix(&s) * l, f64::abs);
                let reduced = (q.transpose() * p * q) * op.area;
                let b = Fp6Abs.block(&op, &s);
                assert!((reduced - b).norm() <= 1e-10 * b.norm(), "{e:?}: {}", (reduced - b).norm() / b.norm());
                let h = element_hessian(&op, &s);
                let (eh, eb) = (h.symmetric_eigenvalues(), b.symmetric_eigenvalues());
                assert!(eb.min() >= -1e-10 * eb.amax(), "{e:?}");
                let mut abs_h: Vec<f64> = eh.iter().map(|v| v.abs()).collect();
                let mut sorted: Vec<f64> = eb.iter().copied().collect();
                abs_h.sort_by(f64::total_cmp);
                sorted.sort_by(f64::total_cmp);
                for (a, b) in abs_h.iter().zip(&sorted) {
                    assert!((a - b).abs() <= 1e-9 * eh.amax(), "{e:?}");
                }
                if eh.min() < -1e-9 * eh.amax() {
                    flipped += 1;
                } else {
                    assert!((b - h).norm() <= 1e-9 * h.norm(), "{e:?}");
                }
            }
            assert!(flipped > 10, "{e:?}: {flipped} indefinite samples");
        }
    }

    #[test]
    fn fp_is_no_farther_from_h_than_kp() {
        // FP is the Frobenius-nearest PSD matrix to H; KP projects K instead.
        let mut rng = Lcg(57);
        for e in all_energies() {
            for _ in 0..200 {
                let (op, _, s) = random_element(&mut rng, &e);
                let h = element_hessian(&op, &s);
                let fp = (Fp6.block(&op, &s) - h).norm();
                let kp = (super::super::kp::Kp.block(&op, &s) - h).norm();
                assert!(fp <= kp * (1.0 + 1e-9) + 1e-12 * h.norm(), "{e:?}");
            }
        }
    }
}
