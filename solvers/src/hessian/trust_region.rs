//! The trust-region rule of the adaptive filters (Chen, Liu, Jacobson, Levin, Zheng,
//! SIGGRAPH Asia 2024; the rule itself is described in [`super::pn`]): which eigenvalue
//! filter the next system uses, in which space, chosen from the last step's model fit.

/// How the negative eigenvalues of `K` are filtered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// `lambda -> max(lambda, 0)` (KP).
    Clamp,
    /// `lambda -> |lambda|`.
    Abs,
}

impl Filter {
    /// The `filter` column: 0 for clamp, 1 for abs.
    pub fn code(self) -> f64 {
        match self {
            Filter::Clamp => 0.0,
            Filter::Abs => 1.0,
        }
    }
}

/// The default `tau` of the trust-region rule (the authors' `--tr 0.01`).
pub const DEFAULT_TAU: f64 = 0.01;

/// A predicted decrease at or below `BAD_FIT_RTOL |E|` is a bad fit: near convergence the
/// model's decrease drowns in round-off and `rho` means nothing.
pub const BAD_FIT_RTOL: f64 = 1e-12;

/// The extra columns of `pn-trust-region`: the filter of the system that produced the row
/// (0 clamp, 1 abs) and the model fit `rho` of its step (NaN for a bad fit; both NaN in row 0).
pub const TRUST_REGION_COLUMNS: [&str; 2] = [FILTER, RHO];

/// The column of the filter used.
pub const FILTER: &str = "filter";

/// The column of the model fit.
pub const RHO: &str = "rho";

/// What a filter acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// `K` through its analytic eigensystem ([`Filtered`](super::pn::Filtered), KP's metric).
    K,
    /// The 6x6 element Hessian, numerically ([`Fp6`](super::fp::Fp6) clamps,
    /// [`Fp6Abs`](super::fp::Fp6Abs) takes |lambda|).
    Element,
}

/// `pn-trust-region` and `fp-trust-region-6x6`: the driver builds each system with
/// [`TrustRegion::system`] in the mode that [`TrustRegion::next`] chose from the last step's fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrustRegion {
    /// Clamp when the last step's model fit has `|rho - 1| < tau`, else abs.
    pub tau: f64,
    /// What the filters act on: `K` or the 6x6 element Hessian.
    pub space: Space,
}

impl TrustRegion {
    /// The filter before any step has been taken.
    pub const FIRST: Filter = Filter::Abs;

    /// The filter after a step whose model fit was `rho` (NaN: a bad fit).
    pub fn next(&self, rho: f64) -> Filter {
        if (rho - 1.0).abs() < self.tau {
            Filter::Clamp
        } else {
            Filter::Abs
        }
    }

    /// `rho = actual / predicted`, NaN when `predicted <= BAD_FIT_RTOL |energy|` (or not finite).
    pub fn fit(actual: f64, predicted: f64, energy: f64) -> f64 {
        if predicted > BAD_FIT_RTOL * energy.abs() && predicted.is_finite() {
            actual / predicted
        } else {
            f64::NAN
        }
    }
}
