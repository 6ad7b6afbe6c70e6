//! AKVF (Claici et al. 2017, "Isometry-aware preconditioning"): the system matrix is the
//! Killing energy of a P1 vector field `V` on the *current* map, weighted by the source
//! area, `V^T K V = 4 A_src |sym grad V|_F^2` (reference notes section 4). The step
//! `d = -K^{-1} grad E` is a preconditioned gradient step; it shares the injective
//! Armijo line search with the Newton variants, as in the complex-view reference code.
//!
//! The current triangle is recovered from the element state: source edges from the local
//! operator (`e_k = 4A (Im D_k, Re D_k)`, the inverse of `D = i/(4A) conj(e)`), mapped by
//! the element's Jacobian.

use super::element::ElementState;
use super::slim::jacobian;
use super::system_block::SystemBlock;
use crate::local::LocalOp;
use nalgebra::{Matrix2, Matrix6, Vector2};

/// AKVF's system block: the Killing-energy matrix of P1 vector fields on the current map.
#[derive(Clone, Copy, Debug, Default)]
pub struct Akvf;

/// Edges `e_k` (opposite vertex `k`) of the current image of the element's triangle.
pub fn current_edges(op: &LocalOp, s: &ElementState) -> [Vector2<f64>; 3] {
    let j = jacobian(s);
    let a4 = 4.0 * op.area;
    [0, 1, 2].map(|k| j * Vector2::new(a4 * op.d_im[k], a4 * op.d_re[k]))
}

impl SystemBlock for Akvf {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        let e = current_edges(op, s);
        // Current signed area, (x - y) A for an orientation-preserving map.
        let area = 0.5 * (e[2].x * e[1].y - e[2].y * e[1].x);
        // grad phi_k = rot90(e_k) / (2 A') for the barycentric basis functions.
        let grad = e.map(|ek| Vector2::new(-ek.y, ek.x) / (2.0 * area));
        // sym(grad V) for the unit field in local dof i (u_k or v_k).
        let basis: [Matrix2<f64>; 6] = std::array::from_fn(|i| {
            let (k, c) = (i / 2, i % 2);
            let mut g = Matrix2::zeros();
            g[(c, 0)] = grad[k].x;
            g[(c, 1)] = grad[k].y;
            (g + g.transpose()) * 0.5
        });
        let w = 4.0 * op.area;
        Matrix6::from_fn(|i, j| w * basis[i].component_mul(&basis[j]).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::Lcg;
    use crate::energy::{EnergyKind, Sd};
    use crate::hessian::tests::random_element;
    use nalgebra::Vector6;

    #[test]
    fn current_edges_are_the_image_triangle() {
        let mut rng = Lcg(81);
        for _ in 0..100 {
            let (op, y, s) = random_element(&mut rng, &EnergyKind::Sd(Sd));
            let e = current_edges(&op, &s);
            for k in 0..3 {
                let (a, b) = (y[(k + 1) % 3], y[(k + 2) % 3]);
                let want = Vector2::new(a[0] - b[0], a[1] - b[1]);
                assert!((e[k] - want).norm() <= 1e-10 * want.norm().max(1.0), "{k}");
            }
        }
    }

    /// The reference codes' closed form (AKVFParam / meshNewton `AKVFC.cpp`): edges scaled
    /// by `s = A' sqrt(2 / A)`, `K[u_i,u_j] = x_i x_j + 2 y_i y_j`, `K[v_i,v_j] = 2 x_i x_j + y_i y_j`,
    /// `K[u_i,v_j] = -x_i y_j`.
    fn reference_block(op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        let e = current_edges(op, s);
        let area = 0.5 * (e[2].x * e[1].y - e[2].y * e[1].x);
        let sc = area * (2.0 / op.area).sqrt();
        let (x, y) = (e.map(|v| v.x / sc), e.map(|v| v.y / sc));
        Matrix6::from_fn(|a, b| {
            let (i, ca, j, cb) = (a / 2, a % 2, b / 2, b % 2);
            match (ca, cb) {
                (0, 0) => x[i] * x[j] + 2.0 * y[i] * y[j],
                (1, 1) => 2.0 * x[i] * x[j] + y[i] * y[j],
                (0, 1) => -x[i] * y[j],
                _ => -y[i] * x[j],
            }
        })
    }

    #[test]
    fn equals_the_reference_closed_form_and_is_psd() {
        let mut rng = Lcg(83);
        for _ in 0..300 {
            let (op, _, s) = random_element(&mut rng, &EnergyKind::Sd(Sd));
            let k = Akvf.block(&op, &s);
            let r = reference_block(&op, &s);
            assert!((k - r).norm() <= 1e-10 * r.norm(), "{k} vs {r}");
            let ev = k.symmetric_eigenvalues();
            assert!(ev.min() >= -1e-10 * ev.amax());
        }
    }

    #[test]
    fn annihilates_rigid_motions_only() {
        let mut rng = Lcg(85);
        for _ in 0..100 {
            let (op, y, s) = random_element(&mut rng, &EnergyKind::Sd(Sd));
            let k = Akvf.block(&op, &s);
            let tx = Vector6::new(1.0, 0.0, 1.0, 0.0, 1.0, 0.0);
            let ty = Vector6::new(0.0, 1.0, 0.0, 1.0, 0.0, 1.0);
            // infinitesimal rotation about the origin: V(p) = (-p_y, p_x) at the current vertices
            let rot = Vector6::new(-y[0][1], y[0][0], -y[1][1], y[1][0], -y[2][1], y[2][0]);
            for v in [tx, ty, rot] {
                assert!((k * v).norm() <= 1e-10 * k.norm() * v.norm(), "{}", (k * v).norm());
            }
            // a stretch is not a Killing field
            let stretch = Vector6::new(y[0][0], 0.0, y[1][0], 0.0, y[2][0], 0.0);
            assert!(stretch.dot(&(k * stretch)) > 1e-6 * k.norm() * stretch.norm_squared());
            // rank 3: exactly three (near-)zero eigenvalues
            let ev = k.symmetric_eigenvalues();
            assert_eq!(ev.iter().filter(|&&l| l.abs() <= 1e-10 * ev.amax()).count(), 3);
        }
    }

    #[test]
    fn quadratic_form_is_the_area_weighted_killing_energy() {
        // V^T K V = 4 A_src |sym grad V|^2 with grad V computed by finite differences of the
        // linear interpolant on the current triangle (independent of the basis formulas).
        let mut rng = Lcg(87);
        for _ in 0..100 {
            let (op, y, s) = random_element(&mut rng, &EnergyKind::Sd(Sd));
            let v: Vector6<f64> = Vector6::from_fn(|_, _| rng.range(-1.0, 1.0));
            // Solve for the affine field V(p) = G p + c through the three vertex values.
            let p = |k: usize| Vector2::new(y[k][0], y[k][1]);
            let dp = Matrix2::from_columns(&[p(1) - p(0), p(2) - p(0)]);
            let dv = Matrix2::from_columns(&[
                Vector2::new(v[2] - v[0], v[3] - v[1]),
                Vector2::new(v[4] - v[0], v[5] - v[1]),
            ]);
            let g = dv * dp.try_inverse().unwrap();
            let sym = (g + g.transpose()) * 0.5;
            let want = 4.0 * op.area * sym.norm_squared();
            let got = v.dot(&(Akvf.block(&op, &s) * v));
            assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "{got} vs {want}");
        }
    }
}
