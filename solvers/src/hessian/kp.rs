//! KP: the analytic PSD projection of `K` (complex-view paper, Eq. 4 and Appendix B).
//!
//! The eigenvalues of `K` are clamped at zero in `K`'s own Euclidean metric, then
//! `H+ = A M^T K+ M`. For SD, ExpSD, BCONF (k <= 1) and BARAP (k <= 2) only `2 a1` can be
//! negative and this reduces to Eq. 4 (`a1' = max(a1, 0)`, `b1' = b1 + min(a1, 0)/(2|f_z|^2)`);
//! for NH, SARAP and larger k the radial block is clamped too (the reference code's
//! "branch B", which equals the eigen-clamp). A `K` that is already PSD is returned as is.

use super::{k_eigen, k_matrix, triple_product, ElementState, SystemBlock};
use crate::local::LocalOp;
use nalgebra::{Matrix4, Matrix6};

/// The PSD projection of `K`.
pub fn project_k(s: &ElementState) -> Matrix4<f64> {
    // The case is decided on the eigensystem's own values, not `k_eigenvalues`: the two
    // differ by round-off, which flips the case for eigenvalues at zero and changed SARAP's
    // iteration counts on the CI gate (hand_smpl 124 -> 137).
    let e = k_eigen(s);
    if e.values.iter().all(|&v| v >= 0.0) {
        return k_matrix(s);
    }
    if e.values[1..].iter().all(|&v| v >= 0.0) {
        // Only the cone eigenvalue 2 a1 is negative (always the case for SD, ExpSD, BCONF
        // k <= 1, BARAP k <= 2): Eq. 4 clamps it in the modifiers, leaving the radial block
        // unchanged. Same result as the eigen-clamp, cheaper, and the same arithmetic as
        // CM's cone term, so `cm` and `kp-newton-noscale` produce identical iterates.
        let mut t = *s;
        t.m.b1 += t.m.a1 / (2.0 * s.x());
        t.m.a1 = 0.0;
        return k_matrix(&t);
    }
    let mut k = Matrix4::zeros();
    for i in 0..4 {
        if e.values[i] > 0.0 {
            k += e.vectors[i] * e.vectors[i].transpose() * e.values[i];
        }
    }
    k
}

/// KP-Newton's system block.
#[derive(Clone, Copy, Debug, Default)]
pub struct Kp;

impl SystemBlock for Kp {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        triple_product(op, &project_k(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, Lcg};
    use crate::energy::EnergyKind;
    use crate::hessian::tests::random_element;
    use crate::hessian::{count_negative, element_hessian};

    #[test]
    fn projected_block_is_psd_for_every_energy() {
        let mut rng = Lcg(13);
        for e in all_energies() {
            let mut saw_negative = false;
            for _ in 0..500 {
                let (op, _, s) = random_element(&mut rng, &e);
                saw_negative |= count_negative(&s) > 0;
                let h = Kp.block(&op, &s);
                let ev = h.symmetric_eigenvalues();
                assert!(ev.min() >= -1e-10 * ev.amax().max(1.0), "{e:?}: {ev}");
                let kev = project_k(&s).symmetric_eigenvalues();
                assert!(kev.min() >= -1e-12 * kev.amax().max(1.0));
            }
            assert!(saw_negative, "{e:?}: sampling never hit an indefinite state");
        }
    }

    #[test]
    fn psd_k_is_left_unchanged() {
        let mut rng = Lcg(17);
        let mut n_psd = 0;
        for e in all_energies() {
            for _ in 0..500 {
                let (op, _, s) = random_element(&mut rng, &e);
                if count_negative(&s) == 0 && k_eigen(&s).values.iter().all(|&v| v >= 0.0) {
                    n_psd += 1;
                    assert_eq!(project_k(&s), k_matrix(&s));
                    assert_eq!(Kp.block(&op, &s), element_hessian(&op, &s));
                }
            }
        }
        assert!(n_psd > 100);
    }

    #[test]
    fn sd_projection_is_eq4() {
        // Eq. 4: a1' = max(a1, 0), b1' = b1 + min(a1, 0) / (2 |f_z|^2)
        let mut rng = Lcg(19);
        let mut n = 0;
        for _ in 0..500 {
            let (_, _, s) = random_element(&mut rng, &EnergyKind::Sd);
            if s.m.a1 >= 0.0 {
                continue;
            }
            n += 1;
            let mut t = s;
            t.m.b1 = s.m.b1 + s.m.a1 / (2.0 * s.x());
            t.m.a1 = 0.0;
            let (p, q) = (project_k(&s), k_matrix(&t));
            assert!((p - q).norm() <= 1e-10 * q.norm());
        }
        assert!(n > 20);
    }

    #[test]
    fn projection_is_closest_psd_in_k_metric() {
        // Clamping K's eigenvalues is the Frobenius-nearest PSD matrix to K: compare with
        // nalgebra's numeric eigendecomposition.
        let mut rng = Lcg(23);
        for e in all_energies() {
            for _ in 0..100 {
                let (_, _, s) = random_element(&mut rng, &e);
                let k = k_matrix(&s);
                let se = k.symmetric_eigen();
                let mut clamped = Matrix4::zeros();
                for i in 0..4 {
                    let v = se.eigenvectors.column(i);
                    clamped += v * v.transpose() * se.eigenvalues[i].max(0.0);
                }
                assert!((clamped - project_k(&s)).norm() <= 1e-9 * k.norm().max(1.0), "{e:?}");
            }
        }
    }
}
