//! SLIM (Rabinovich et al. 2017) as a system-matrix strategy: the Hessian of the local
//! proxy `A ||W (J - R)||_F^2`, with `R` the closest rotation to `J` and the weights
//! `W = U diag(w1, w2) U^T`, `w_k^2 = (dpsi/dsigma_k) / (2 (sigma_k - 1))`, chosen so that
//! the proxy's gradient equals the energy's gradient at the current map (notes section 3).
//! The Newton driver solves with the true gradient, so the step is SLIM's global step,
//! followed by the shared injective line search. A proximal term `1e-4 I` keeps the
//! system definite (libigl's default).
//!
//! Singular values come from the complex view: with `f_z = |a| e^{i ta}`, `f_zbar = |b| e^{i tb}`,
//! `sigma1 = |a| + |b|`, `sigma2 = |a| - |b|`, left singular vectors at angle `(ta + tb)/2`
//! and right ones at `(tb - ta)/2`.

use super::element::{triple_product, ElementState};
use super::system_block::SystemBlock;
use crate::local::LocalOp;
use nalgebra::{Matrix2, Matrix4, Matrix6, Vector2};
use rayon::prelude::*;

/// Proximal weight of libigl's SLIM.
pub const PROXIMAL: f64 = 1e-4;
/// Smallest weight: non-convex densities can have `dpsi/dsigma` of the "wrong" sign.
pub const MIN_WEIGHT_SQ: f64 = 1e-8;

/// Signed SVD of the element's Jacobian from its Wirtinger derivatives.
#[derive(Clone, Copy, Debug)]
pub struct Svd2 {
    /// Signed singular values `(|f_z| + |f_zbar|, |f_z| - |f_zbar|)`; the second is negative where the map inverts.
    pub sigma: [f64; 2],
    /// `U`: the left singular vectors, a rotation.
    pub u: Matrix2<f64>,
    /// `V`: the right singular vectors, a rotation.
    pub v: Matrix2<f64>,
}

/// The signed SVD `J = U diag(sigma) V^T` of the element's Jacobian, from `f_z` and `f_zbar`.
pub fn svd(s: &ElementState) -> Svd2 {
    let (a, b) = (s.x().sqrt(), s.y().sqrt());
    let ta = s.fz[1].atan2(s.fz[0]);
    // f_zbar = 0: any angle works; take ta so that U = V.
    let tb = if b > 0.0 { s.fzb[1].atan2(s.fzb[0]) } else { ta };
    let rot = |t: f64| {
        let (sn, cs) = t.sin_cos();
        Matrix2::new(cs, -sn, sn, cs)
    };
    Svd2 { sigma: [a + b, a - b], u: rot(0.5 * (ta + tb)), v: rot(0.5 * (tb - ta)) }
}

/// The Jacobian `J = [[dU/ds, dU/dt], [dV/ds, dV/dt]]` of the element map.
pub fn jacobian(s: &ElementState) -> Matrix2<f64> {
    let (a, b) = (s.fz, s.fzb);
    Matrix2::new(a[0] + b[0], -a[1] + b[1], a[1] + b[1], a[0] - b[0])
}

/// `P` with `vec(J) = P (f_z, f_zbar)`, `vec` column-major.
fn p_matrix() -> Matrix4<f64> {
    Matrix4::new(
        1.0, 0.0, 1.0, 0.0, //
        0.0, 1.0, 0.0, 1.0, //
        0.0, -1.0, 0.0, 1.0, //
        1.0, 0.0, -1.0, 0.0,
    )
}

/// Squared SLIM weights for `sigma = (sigma1, sigma2)` from the density's derivatives in
/// the singular values (from the modifiers: `dpsi/dsigma1 = a1 |f_z| + a2 |f_zbar|`,
/// `dpsi/dsigma2 = a1 |f_z| - a2 |f_zbar|`). Where `|sigma - 1| < 1e-8` the limit
/// `d2psi/dsigma^2 / 2` is used.
pub fn weights_sq(s: &ElementState) -> [f64; 2] {
    raw_weights_sq(s).map(|raw| if raw.is_finite() { raw.max(MIN_WEIGHT_SQ) } else { MIN_WEIGHT_SQ })
}

/// The squared weights before clamping (possibly non-positive or non-finite).
fn raw_weights_sq(s: &ElementState) -> [f64; 2] {
    let (a, b) = (s.x().sqrt(), s.y().sqrt());
    let sig = [a + b, a - b];
    let (d2, d1) = sigma_derivatives(s);
    std::array::from_fn(|k| if (sig[k] - 1.0).abs() < 1e-8 { 0.5 * d2[k] } else { d1[k] / (2.0 * (sig[k] - 1.0)) })
}

/// How many of the element's two weights [`weights_sq`] clamps to [`MIN_WEIGHT_SQ`]: where
/// `dpsi/dsigma_k` does not have the sign of `sigma_k - 1` (or is not finite) the reweighting
/// has no positive weight, and the proxy's gradient is no longer the energy's.
pub fn clamped_weights(s: &ElementState) -> usize {
    raw_weights_sq(s).iter().filter(|raw| !(raw.is_finite() && **raw >= MIN_WEIGHT_SQ)).count()
}

/// `(d2psi/dsigma_k^2, dpsi/dsigma_k)` from the modifiers by the chain rule through
/// `x = ((s1 + s2)/2)^2`, `y = ((s1 - s2)/2)^2`.
fn sigma_derivatives(s: &ElementState) -> ([f64; 2], [f64; 2]) {
    let (a, b) = (s.x().sqrt(), s.y().sqrt());
    let m = &s.m;
    let d1 = [m.a1 * a + m.a2 * b, m.a1 * a - m.a2 * b];
    let d2 = [
        m.b1 * a * a + 2.0 * m.b3 * a * b + m.b2 * b * b + 0.5 * (m.a1 + m.a2),
        m.b1 * a * a - 2.0 * m.b3 * a * b + m.b2 * b * b + 0.5 * (m.a1 + m.a2),
    ];
    (d2, d1)
}

/// SLIM's system block: the Hessian of its reweighted proxy, with the proximal shift.
#[derive(Clone, Copy, Debug, Default)]
pub struct Slim;

impl Slim {
    /// `W^2 = U diag(w1^2, w2^2) U^T`.
    pub fn w_sq(s: &ElementState) -> Matrix2<f64> {
        let d = svd(s);
        let w = weights_sq(s);
        d.u * Matrix2::from_diagonal(&Vector2::new(w[0], w[1])) * d.u.transpose()
    }
}

impl SystemBlock for Slim {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        // Hessian of ||W (J - R)||^2 in vec(J) is blockdiag(2 W^2, 2 W^2).
        let w = Self::w_sq(s) * 2.0;
        // Entry by entry rather than through block views (see `k_matrix`).
        #[rustfmt::skip]
        let hj = Matrix4::new(
            w[(0, 0)], w[(0, 1)], 0.0, 0.0,
            w[(1, 0)], w[(1, 1)], 0.0, 0.0,
            0.0, 0.0, w[(0, 0)], w[(0, 1)],
            0.0, 0.0, w[(1, 0)], w[(1, 1)],
        );
        let p = p_matrix();
        triple_product(op, &(p.transpose() * hj * p))
    }

    fn diagonal_shift(&self) -> f64 {
        PROXIMAL
    }

    fn counter_names(&self) -> &'static [&'static str] {
        &CLAMPED_COLUMN
    }

    /// The weights clamped in the system, of two per element.
    fn counters(&self, states: &[ElementState]) -> Vec<(&'static str, f64)> {
        vec![(CLAMPED, states.par_iter().map(clamped_weights).sum::<usize>() as f64)]
    }
}

/// SLIM's per-iteration column: the weights clamped in the system that produced the row.
pub const CLAMPED: &str = "clamped";

/// SLIM's per-iteration columns.
pub const CLAMPED_COLUMN: [&str; 1] = [CLAMPED];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, Lcg};
    use crate::energy::{EnergyKind, Sd};
    use crate::hessian::element_gradient;
    use crate::hessian::tests::random_element;
    use nalgebra::Vector4;

    #[test]
    fn complex_view_svd_reproduces_j() {
        let mut rng = Lcg(81);
        for _ in 0..500 {
            let (_, _, s) = random_element(&mut rng, &EnergyKind::Sd(Sd));
            let d = svd(&s);
            let j = jacobian(&s);
            let rebuilt = d.u * Matrix2::from_diagonal(&Vector2::new(d.sigma[0], d.sigma[1])) * d.v.transpose();
            assert!((rebuilt - j).norm() < 1e-12 * j.norm());
            let sv = j.singular_values();
            assert!((sv.max() - d.sigma[0]).abs() < 1e-12 && (sv.min() - d.sigma[1]).abs() < 1e-12);
            // vec(J) = P (f_z, f_zbar)
            let vj = p_matrix() * Vector4::new(s.fz[0], s.fz[1], s.fzb[0], s.fzb[1]);
            assert!((vj - Vector4::new(j[(0, 0)], j[(1, 0)], j[(0, 1)], j[(1, 1)])).norm() < 1e-13);
        }
    }

    #[test]
    fn proxy_gradient_equals_energy_gradient() {
        // d/dY of A ||W (J(Y) - R)||^2 at the current map = A G^T vec(2 W^2 (J - R)) with
        // R = U V^T; it must equal the energy gradient wherever the weights are not clamped.
        let mut rng = Lcg(83);
        for e in all_energies() {
            let mut checked = 0;
            for _ in 0..300 {
                let (op, _, s) = random_element(&mut rng, &e);
                let w = weights_sq(&s);
                if w.iter().any(|&v| v <= MIN_WEIGHT_SQ) {
                    continue; // clamped weight: SLIM is not gradient-consistent there
                }
                checked += 1;
                let d = svd(&s);
                let j = jacobian(&s);
                let r = d.u * d.v.transpose();
                let gj = Slim::w_sq(&s) * (j - r) * 2.0;
                let vg = Vector4::new(gj[(0, 0)], gj[(1, 0)], gj[(0, 1)], gj[(1, 1)]);
                let proxy = op.m().transpose() * (p_matrix().transpose() * vg) * op.area;
                let true_g = element_gradient(&op, &s);
                assert!((proxy - true_g).norm() <= 1e-8 * true_g.norm().max(1e-12), "{e:?}");
            }
            assert!(checked > 50, "{e:?}: {checked}");
        }
    }

    #[test]
    fn slim_block_is_psd() {
        let mut rng = Lcg(87);
        for e in all_energies() {
            for _ in 0..200 {
                let (op, _, s) = random_element(&mut rng, &e);
                let ev = Slim.block(&op, &s).symmetric_eigenvalues();
                assert!(ev.min() >= -1e-10 * ev.amax(), "{e:?}");
            }
        }
    }

    #[test]
    fn singular_value_second_derivatives_match_finite_differences() {
        // psi as a function of (sigma1, sigma2): x = ((s1 + s2)/2)^2, y = ((s1 - s2)/2)^2
        let mut rng = Lcg(89);
        for e in all_energies() {
            for _ in 0..100 {
                let (s1, s2) = (rng.range(0.8, 2.0), rng.range(0.3, 0.79));
                let psi = |s1: f64, s2: f64| e.value((0.5 * (s1 + s2)).powi(2), (0.5 * (s1 - s2)).powi(2));
                let h = 1e-4;
                let fd = [
                    (psi(s1 + h, s2) - 2.0 * psi(s1, s2) + psi(s1 - h, s2)) / (h * h),
                    (psi(s1, s2 + h) - 2.0 * psi(s1, s2) + psi(s1, s2 - h)) / (h * h),
                ];
                let (a, b) = (0.5 * (s1 + s2), 0.5 * (s1 - s2));
                let m = e.modifiers(a * a, b * b).unwrap();
                let st = ElementState { fz: [a, 0.0], fzb: [b, 0.0], m };
                let (d2, _) = sigma_derivatives(&st);
                for k in 0..2 {
                    assert!((d2[k] - fd[k]).abs() < 1e-4 * fd[k].abs().max(1.0), "{e:?} {k}: {} vs {}", d2[k], fd[k]);
                }
            }
        }
    }

    /// SD, exp-SD and SARAP are sums of per-singular-value terms falling towards `sigma = 1`:
    /// their weights are never clamped. NH, BARAP and BCONF couple the singular values through
    /// `det J`, and many weights are (the catalogue leaves them out of SLIM's energies).
    #[test]
    fn weights_are_clamped_only_for_the_energies_without_rotation_minima_per_singular_value() {
        let mut rng = Lcg(91);
        for e in all_energies() {
            let states: Vec<ElementState> = (0..2000).map(|_| random_element(&mut rng, &e).2).collect();
            let counters = Slim.counters(&states);
            let separable = matches!(e, EnergyKind::Sd(_) | EnergyKind::ExpSd(_) | EnergyKind::Sarap(_));
            assert_eq!((counters.len(), counters[0].0), (1, CLAMPED));
            let clamped = counters[0].1;
            assert_eq!(clamped == 0.0, separable, "{e:?}: {clamped} of 4000 clamped");
            // the count is of the weights `weights_sq` clamps
            let at_floor: usize =
                states.iter().map(|s| weights_sq(s).iter().filter(|&&w| w == MIN_WEIGHT_SQ).count()).sum();
            assert_eq!(clamped, at_floor as f64, "{e:?}");
        }
    }

    #[test]
    fn weights_at_the_isometry_use_the_limit() {
        let m = EnergyKind::Sd(Sd).modifiers(1.0, 0.0).unwrap();
        let s = ElementState { fz: [1.0, 0.0], fzb: [0.0, 0.0], m };
        // psi_SD = (s^2 + s^-2)/2 per singular value: psi'' = 1 + 3 s^-4 = 4 at s = 1
        let w = weights_sq(&s);
        assert!((w[0] - 2.0).abs() < 1e-12 && (w[1] - 2.0).abs() < 1e-12);
    }
}
