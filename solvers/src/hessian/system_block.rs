//! The strategy of a Newton-type solver: how an evaluated element becomes its block of the
//! Newton system.

use super::element::ElementState;
use super::trust_region::TrustRegion;
use crate::local::LocalOp;
use nalgebra::Matrix6;

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

    /// The counters of the system built from `states`, each named by its column (of
    /// [`SystemBlock::counter_names`]), e.g. SLIM's clamped weights.
    fn counters(&self, _states: &[ElementState]) -> Vec<(&'static str, f64)> {
        Vec::new()
    }

    /// The trust-region rule of an adaptive filter (`pn-trust-region`, `fp-trust-region-6x6`):
    /// the driver then builds each system with [`TrustRegion::system`] in the mode the rule
    /// chose from the last step's model fit, and writes the mode and the fit as the strategy's
    /// counters.
    fn trust_region(&self) -> Option<TrustRegion> {
        None
    }
}
