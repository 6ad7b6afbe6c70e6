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
mod element;
pub mod fp;
pub mod kp;
pub mod none;
pub mod pn;
pub mod slim;
mod system_block;
pub mod trust_region;

pub use element::{
    count_negative, element_gradient, element_hessian, k_eigen, k_eigenvalues, k_matrix, triple_product, ElementState,
    KEigen, NEG_EIG_RTOL,
};
pub use system_block::SystemBlock;

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, random_xy, Lcg};
    use crate::energy::{EnergyKind, Sd};
    use crate::local::LocalOp;
    use nalgebra::{Matrix4, Vector4, Vector6};

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
