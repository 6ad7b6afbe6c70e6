//! CM: composite majorization (Shtengel et al. 2017) expressed as a modification of the
//! modifiers of `K` (complex-view paper, Section 5, Table 3 and Appendix C).
//!
//! For `E = h(sigma1, sigma2)` with a convex-concave split `h = h+ + h-`:
//! `a1' = (a1)+`, `a2' = (a2)+`,
//! `b1' = b1 + (a1)-/(2x) - (h-_uu + h-_vv + 2 h-_uv)/(4x)`,
//! `b2' = b2 + (a2)-/(2y) - (h-_uu + h-_vv - 2 h-_uv)/(4y)`,
//! `b3' = b3 - (h-_uu - h-_vv)/(4 sqrt(xy))`.
//! For neo-Hookean the split is of `g = (||J||_F, det J)`: `a1' = mu/|J| + (h_v)+`,
//! `a2' = mu/|J| - (h_v)-` with `h_v = -mu (x+y)/|J|^2 + kappa (|J| - 1)`, betas unchanged.

use super::element::{k_matrix, triple_product, ElementState};
use super::system_block::SystemBlock;
use crate::energy::{ConvexSplit, EnergyKind};
use crate::local::LocalOp;
use nalgebra::Matrix6;

/// Below this `y/x` the direction of `f_zbar` is undefined and terms divided by `y` are
/// skipped (they multiply `f_zbar f_zbar^T` and vanish with it).
const Y_EPS: f64 = 1e-40;

/// CM's system block for one energy, from its convex-concave split ([`Cm::for_energy`]).
#[derive(Clone, Copy, Debug)]
pub struct Cm {
    split: ConvexSplit,
}

impl Cm {
    /// The majorizer for `energy`, or the reason it is not defined.
    pub fn for_energy(energy: &EnergyKind) -> Result<Cm, String> {
        let split =
            energy.convex_split().map_err(|why| format!("cm: {why} and no convex-concave split is defined for it"))?;
        Ok(Cm { split })
    }

    /// The CM-modified element state (modifiers altered as in Table 3).
    pub fn modify(&self, s: &ElementState) -> ElementState {
        let (x, y) = (s.x(), s.y());
        let mut t = *s;
        let m = &mut t.m;
        if let ConvexSplit::NeoHookean { mu, kappa } = self.split {
            let d = x - y;
            let hv = -mu * (x + y) / (d * d) + kappa * (d - 1.0);
            m.a1 = mu / d + hv.max(0.0);
            m.a2 = mu / d - hv.min(0.0);
            return t;
        }
        // Cone terms: clamp the alphas, keeping the radial curvature (Eq. 4 analogue).
        if m.a1 < 0.0 {
            m.b1 += m.a1 / (2.0 * x);
            m.a1 = 0.0;
        }
        let y_ok = y > Y_EPS * x;
        if m.a2 < 0.0 {
            if y_ok {
                m.b2 += m.a2 / (2.0 * y);
            }
            m.a2 = 0.0;
        }
        if self.split == ConvexSplit::Sarap && y_ok {
            let v = x.sqrt() - y.sqrt();
            if v > 1.5 {
                let hvv_concave = 6.0 / v.powi(4) - 4.0 / v.powi(3);
                m.b1 -= hvv_concave / (4.0 * x);
                m.b2 -= hvv_concave / (4.0 * y);
                m.b3 += hvv_concave / (4.0 * (x * y).sqrt());
            }
        }
        t
    }
}

impl SystemBlock for Cm {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        triple_product(op, &k_matrix(&self.modify(s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::Lcg;
    use crate::energy::{Barap, Bconf, ExpSd, Nh, Sarap, Sd};
    use crate::hessian::kp::Kp;
    use crate::hessian::tests::random_element;
    use crate::hessian::{count_negative, element_hessian};

    #[test]
    fn equals_kp_where_h_is_convex() {
        let mut rng = Lcg(61);
        for e in [
            EnergyKind::Sd(Sd),
            EnergyKind::Bconf(Bconf { k: 0.1 }),
            EnergyKind::Bconf(Bconf { k: 1.0 }),
            EnergyKind::Barap(Barap { k: 0.1 }),
            EnergyKind::Barap(Barap { k: 2.0 }),
        ] {
            let cm = Cm::for_energy(&e).unwrap();
            let mut indefinite = 0;
            for _ in 0..500 {
                let (op, _, s) = random_element(&mut rng, &e);
                indefinite += usize::from(count_negative(&s) > 0);
                let a = cm.block(&op, &s);
                let b = Kp.block(&op, &s);
                assert!((a - b).norm() <= 1e-10 * b.norm(), "{e:?}");
            }
            assert!(indefinite > 10, "{e:?}");
        }
    }

    #[test]
    fn cm_block_is_psd_for_every_supported_energy() {
        let mut rng = Lcg(67);
        for e in [
            EnergyKind::Sd(Sd),
            EnergyKind::ExpSd(ExpSd { s: 0.3 }),
            EnergyKind::Sarap(Sarap),
            EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 }),
            EnergyKind::Nh(Nh { mu: 1.0, kappa: 0.1 }),
        ] {
            let cm = Cm::for_energy(&e).unwrap();
            for _ in 0..1000 {
                let (op, _, s) = random_element(&mut rng, &e);
                let ev = cm.block(&op, &s).symmetric_eigenvalues();
                assert!(ev.min() >= -1e-9 * ev.amax(), "{e:?}: {ev}");
            }
        }
    }

    #[test]
    fn cm_differs_from_kp_for_nh() {
        let mut rng = Lcg(71);
        // NH: CM keeps the betas and shifts the alphas, unlike the eigen-clamp.
        let e = EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 });
        let cm = Cm::for_energy(&e).unwrap();
        let differs = (0..500).any(|_| {
            let (op, _, s) = random_element(&mut rng, &e);
            (cm.block(&op, &s) - Kp.block(&op, &s)).norm() > 1e-6 * element_hessian(&op, &s).norm()
        });
        assert!(differs, "{e:?}");
    }

    #[test]
    fn cm_equals_kp_for_sarap() {
        // In the basis (f/|f|, g/|g|) the radial block of K is T (hess h) T with
        // T = [[1, 1], [1, -1]] (u = |f| + |g|, v = |f| - |g|), i.e. 2 Q (hess h) Q^T with
        // Q = T / sqrt(2) orthogonal. SARAP's hess h = diag(2, h_vv) is diagonal, so clamping
        // K's eigenvalues drops exactly the concave h_vv (v > 1.5) that CM moves to h-: the
        // two coincide (the paper's Table 4: 209.9 vs 210.9 iterations).
        let mut rng = Lcg(73);
        let cm = Cm::for_energy(&EnergyKind::Sarap(Sarap)).unwrap();
        let (op, _, _) = random_element(&mut rng, &EnergyKind::Sarap(Sarap));
        for (a, b) in [(2.0, 0.1), (3.0, 0.8), (2.5, 0.6), (4.0, 2.0), (1.2, 0.3)] {
            let m = EnergyKind::Sarap(Sarap).modifiers(a * a, b * b).unwrap();
            let s = ElementState { fz: [a, 0.0], fzb: [0.0, b], m };
            let (c, k) = (cm.block(&op, &s), Kp.block(&op, &s));
            assert!((c - k).norm() <= 1e-10 * k.norm());
        }
        for _ in 0..500 {
            let (op, _, s) = random_element(&mut rng, &EnergyKind::Sarap(Sarap));
            let (c, k) = (cm.block(&op, &s), Kp.block(&op, &s));
            assert!((c - k).norm() <= 1e-9 * k.norm());
        }
    }

    #[test]
    fn undefined_majorizers_are_reported() {
        let err = Cm::for_energy(&EnergyKind::Bconf(Bconf { k: 1.5 })).unwrap_err();
        assert!(err.contains("k = 1.5") && err.contains("k <= 1"), "{err}");
        assert!(Cm::for_energy(&EnergyKind::Barap(Barap { k: 3.0 })).is_err());
    }
}
