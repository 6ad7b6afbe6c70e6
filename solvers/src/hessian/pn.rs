//! Projected Newton after the papers: the absolute-value eigenvalue filter (Chen, Liu, Levin,
//! Zheng, Jacobson, SIGGRAPH 2024) and the trust-region choice between it and clamping (Chen,
//! Liu, Jacobson, Levin, Zheng, SIGGRAPH Asia 2024).
//!
//! Both filter `K` (Eq. 3) through its analytic eigensystem, as KP does: clamping maps
//! `lambda -> max(lambda, 0)` ([`super::kp::project_k`]), abs maps `lambda -> |lambda|` (exact
//! zeros stay zero). The papers filter the 6x6 element Hessian `H = A M^T K M`; filtering `K`
//! keeps the inertia but not the magnitudes of `H`'s eigenvalues, so `pn-abs` is the analogue
//! of theirs in KP's metric. `fp-abs-6x6` ([`super::fp::Fp6Abs`]) is theirs, numerically.
//!
//! The trust-region rule (their `main.cpp`): after each accepted step `s = t d`, the model fit
//! `rho = (E(x) - E(x + s)) / -(g^T s + s^T H s / 2)` with the *unfiltered* Hessian `H`; the
//! next system clamps when `|rho - 1| < tau` (default 0.01) and uses abs otherwise, abs also
//! at the first iteration and after a bad fit (a predicted decrease that is not clearly
//! positive). `pn-trust-region` switches between the two filters of `K`; `fp-trust-region-6x6`
//! between clamping and abs of the 6x6 element Hessian in vertex coordinates ([`Space`]), which
//! is the authors' method (TinyAD's per-element projection).

use super::element::{k_eigen, k_matrix, triple_product, ElementState};
use super::fp::{Fp6, Fp6Abs};
use super::kp::project_k;
use super::system_block::SystemBlock;
use super::trust_region::{Filter, Space, TrustRegion, TRUST_REGION_COLUMNS};
use crate::local::LocalOp;
use nalgebra::{Matrix4, Matrix6};

impl Filter {
    /// `K` of `s` filtered.
    pub fn apply(self, s: &ElementState) -> Matrix4<f64> {
        match self {
            Filter::Clamp => project_k(s),
            Filter::Abs => abs_k(s),
        }
    }
}

/// `K` with its eigenvalues replaced by their absolute values; a PSD `K` is returned as is.
pub fn abs_k(s: &ElementState) -> Matrix4<f64> {
    let e = k_eigen(s);
    if e.values.iter().all(|&v| v >= 0.0) {
        return k_matrix(s);
    }
    if e.values[1..].iter().all(|&v| v >= 0.0) {
        // Only the cone eigenvalue 2 a1 (direction i f_z) is negative, as in Eq. 4: flip its
        // sign in the modifiers, `a1' = -a1`, and keep the f_z-block's other eigenvalue
        // `2 a1 + 4 b1 |f_z|^2` with `b1' = b1 + a1 / |f_z|^2`.
        let mut t = *s;
        t.m.b1 += t.m.a1 / s.x();
        t.m.a1 = -t.m.a1;
        return k_matrix(&t);
    }
    let mut k = Matrix4::zeros();
    for (v, &l) in e.vectors.iter().zip(&e.values) {
        k += v * v.transpose() * l.abs();
    }
    k
}

/// A Newton system block with `K` filtered: `Filtered(Filter::Abs)` is `pn-abs`,
/// `Filtered(Filter::Clamp)` has KP's blocks.
#[derive(Clone, Copy, Debug)]
pub struct Filtered(pub Filter);

impl SystemBlock for Filtered {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        triple_product(op, &self.0.apply(s))
    }
}

/// A system block filtered by `filter` in `space`.
#[derive(Clone, Copy, Debug)]
pub struct FilteredIn {
    /// The eigenvalue filter.
    pub filter: Filter,
    /// What the filter acts on: `K` or the 6x6 element Hessian.
    pub space: Space,
}

impl SystemBlock for FilteredIn {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        match (self.space, self.filter) {
            (Space::K, f) => Filtered(f).block(op, s),
            (Space::Element, Filter::Clamp) => Fp6.block(op, s),
            (Space::Element, Filter::Abs) => Fp6Abs.block(op, s),
        }
    }
}

impl TrustRegion {
    /// The system block of the iteration whose filter is `filter`.
    pub fn system(&self, filter: Filter) -> FilteredIn {
        FilteredIn { filter, space: self.space }
    }
}

impl SystemBlock for TrustRegion {
    /// The first iteration's block; the driver switches per iteration ([`SystemBlock::trust_region`]).
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        self.system(Self::FIRST).block(op, s)
    }

    fn counter_names(&self) -> &'static [&'static str] {
        &TRUST_REGION_COLUMNS
    }

    fn trust_region(&self) -> Option<TrustRegion> {
        Some(*self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, Lcg};
    use crate::hessian::tests::random_element;
    use crate::hessian::trust_region::DEFAULT_TAU;
    use crate::hessian::{count_negative, element_hessian};

    /// `K` filtered through nalgebra's numeric eigendecomposition.
    fn numeric_abs(k: &Matrix4<f64>) -> Matrix4<f64> {
        let se = k.symmetric_eigen();
        let mut r = Matrix4::zeros();
        for i in 0..4 {
            let v = se.eigenvectors.column(i);
            r += v * v.transpose() * se.eigenvalues[i].abs();
        }
        r
    }

    #[test]
    fn abs_of_k_is_psd_and_matches_the_numeric_filter() {
        let mut rng = Lcg(61);
        for e in all_energies() {
            let mut negative = 0;
            for _ in 0..500 {
                let (op, _, s) = random_element(&mut rng, &e);
                let k = k_matrix(&s);
                negative += usize::from(count_negative(&s) > 0);
                let a = abs_k(&s);
                assert!((a - numeric_abs(&k)).norm() <= 1e-9 * k.norm().max(1.0), "{e:?}");
                let ev = a.symmetric_eigenvalues();
                assert!(ev.min() >= -1e-12 * ev.amax().max(1.0), "{e:?}: {ev}");
                // the eigenvalues' magnitudes are kept: same Frobenius norm as K (where the
                // norm does not overflow: exp-SD's K reaches 1e160)
                let n = k.norm();
                assert!(!n.is_finite() || (a.norm() - n).abs() <= 1e-10 * n, "{e:?}");
                let h = Filtered(Filter::Abs).block(&op, &s).symmetric_eigenvalues();
                assert!(h.min() >= -1e-10 * h.amax().max(1.0), "{e:?}");
            }
            assert!(negative > 20, "{e:?}: sampling hit {negative} indefinite states");
        }
    }

    #[test]
    fn abs_leaves_a_psd_k_unchanged_and_differs_from_clamping_otherwise() {
        let mut rng = Lcg(67);
        let (mut psd, mut indefinite) = (0, 0);
        for e in all_energies() {
            for _ in 0..500 {
                let (op, _, s) = random_element(&mut rng, &e);
                if k_eigen(&s).values.iter().all(|&v| v >= 0.0) {
                    psd += 1;
                    assert_eq!(abs_k(&s), k_matrix(&s));
                    assert_eq!(Filtered(Filter::Abs).block(&op, &s), element_hessian(&op, &s));
                    assert_eq!(Filtered(Filter::Clamp).block(&op, &s), element_hessian(&op, &s));
                } else {
                    indefinite += 1;
                    // abs - clamp = 2 |negative part|, PSD and non-zero
                    let d = abs_k(&s) - project_k(&s);
                    let ev = d.symmetric_eigenvalues();
                    assert!(ev.min() >= -1e-10 * ev.amax() && ev.amax() > 0.0, "{e:?}");
                }
            }
        }
        assert!(psd > 100 && indefinite > 100, "{psd} {indefinite}");
    }

    #[test]
    fn the_trust_region_rule_switches_on_the_model_fit() {
        let tr = TrustRegion { tau: DEFAULT_TAU, space: Space::K };
        // a hand-made sequence of fits and the filter each one selects for the next system
        let fits = [f64::NAN, 0.5, 0.995, 1.0, 1.009, 1.011, 2.0, -1.0, 0.98, f64::INFINITY];
        let modes: Vec<Filter> = fits.iter().map(|&r| tr.next(r)).collect();
        use Filter::{Abs, Clamp};
        assert_eq!(modes, [Abs, Abs, Clamp, Clamp, Clamp, Abs, Abs, Abs, Abs, Abs]);
        assert_eq!(TrustRegion::FIRST, Abs);
        // a looser tau clamps more often
        assert_eq!(TrustRegion { tau: 0.5, space: Space::Element }.next(0.6), Clamp);
        // the fit: tiny, negative or non-finite predictions are bad fits
        assert_eq!(TrustRegion::fit(1.0, 2.0, 10.0), 0.5);
        assert!(TrustRegion::fit(1.0, 1e-12, 10.0).is_nan());
        assert!(TrustRegion::fit(1.0, -1.0, 10.0).is_nan());
        assert!(TrustRegion::fit(1.0, f64::NAN, 10.0).is_nan());
        assert!(TrustRegion::fit(1.0, f64::INFINITY, 10.0).is_nan());
        assert_eq!((Clamp.code(), Abs.code()), (0.0, 1.0));
    }

    /// Each (space, filter) pair builds the block of the solver it stands for: `K`'s filters
    /// are pn-abs's and KP's blocks, the element space's are FP6-abs's and FP6's.
    #[test]
    fn the_adaptive_system_is_the_filter_of_its_space() {
        let mut rng = Lcg(71);
        for e in all_energies() {
            for _ in 0..100 {
                let (op, _, s) = random_element(&mut rng, &e);
                let of = |space, filter| TrustRegion { tau: DEFAULT_TAU, space }.system(filter).block(&op, &s);
                assert_eq!(of(Space::K, Filter::Abs), Filtered(Filter::Abs).block(&op, &s));
                assert_eq!(of(Space::K, Filter::Clamp), super::super::kp::Kp.block(&op, &s));
                assert_eq!(of(Space::Element, Filter::Abs), Fp6Abs.block(&op, &s));
                assert_eq!(of(Space::Element, Filter::Clamp), Fp6.block(&op, &s));
            }
            let (op, _, s) = random_element(&mut rng, &e);
            for space in [Space::K, Space::Element] {
                let tr = TrustRegion { tau: DEFAULT_TAU, space };
                assert_eq!(tr.block(&op, &s), tr.system(TrustRegion::FIRST).block(&op, &s));
            }
        }
    }
}
