//! Exponential symmetric Dirichlet `exp(s * psi_SD)` with the half SD in the exponent,
//! as in the complex-view reference code (libigl's `exp_factor` f equals s / 2).

use super::density::{ConvexSplit, Density, Modifiers};
use super::sd::Sd;
use serde::{Deserialize, Serialize};

/// Default exponent weight. Tutte initializations with slivers overflow quickly, so the
/// default is mild; set `[energy.exp-sd] s` in the config.
pub const DEFAULT_S: f64 = 0.1;

/// Exponential symmetric Dirichlet with the exponent weight `s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExpSd {
    /// The exponent's weight.
    pub s: f64,
}

impl Default for ExpSd {
    fn default() -> ExpSd {
        ExpSd { s: DEFAULT_S }
    }
}

impl Density for ExpSd {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        (self.s * Sd.value(x, y)).exp()
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let s = self.s;
        let m = Sd.modifiers(x, y);
        let e = (s * m.psi).exp();
        Modifiers {
            psi: e,
            a1: s * e * m.a1,
            a2: s * e * m.a2,
            b1: s * e * (m.b1 + s * m.a1 * m.a1),
            b2: s * e * (m.b2 + s * m.a2 * m.a2),
            b3: s * e * (m.b3 + s * m.a1 * m.a2),
        }
    }

    fn check(&self) -> Result<(), String> {
        super::density::positive("s", self.s, "must be positive")
    }

    fn convex_split(&self) -> Result<ConvexSplit, String> {
        Ok(ConvexSplit::Convex)
    }
}
