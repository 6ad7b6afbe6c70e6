//! Barrier conformal `y + k (|J| + |J|^-1)` (complex-view paper, Section 4.1): the LSCM
//! energy plus a barrier.

use super::density::{ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// The paper's experiments use k = 0.1.
pub const DEFAULT_K: f64 = 0.1;

/// Barrier conformal with the barrier weight `k`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Bconf {
    /// The barrier's weight.
    pub k: f64,
}

impl Default for Bconf {
    fn default() -> Bconf {
        Bconf { k: DEFAULT_K }
    }
}

impl Density for Bconf {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        let d = x - y;
        y + self.k * (d + 1.0 / d)
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let k = self.k;
        let d = x - y;
        let i2 = 1.0 / (d * d);
        let i3 = i2 / d;
        Modifiers {
            psi: self.value(x, y),
            a1: k * (1.0 - i2),
            a2: k * i2 + 1.0 - k,
            b1: 2.0 * k * i3,
            b2: 2.0 * k * i3,
            b3: -2.0 * k * i3,
        }
    }

    fn check(&self) -> Result<(), String> {
        super::density::positive("k", self.k, "must be positive (it weighs the barrier)")
    }

    /// `h = (u - v)^2/4 + k (uv + 1/(uv))` is convex in `(u, v)` iff `k <= 1`.
    fn convex_split(&self) -> Result<ConvexSplit, String> {
        if self.k <= 1.0 {
            return Ok(ConvexSplit::Convex);
        }
        Err(format!("bconf with k = {} is not convex in the singular values (needs k <= 1)", self.k))
    }

    /// `a1(s) = k (1 - (s^2 d)^-2) >= 0`.
    fn psd_scale(&self, x: f64, y: f64) -> Option<f64> {
        Some(1.0 / (x - y).sqrt())
    }
}
