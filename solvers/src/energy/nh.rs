//! Neo-Hookean `mu/2 (||J||_F^2 / |J| - 2) + kappa/2 (|J| - 1)^2 = mu 2y/(x-y) + kappa/2 (x-y-1)^2`.

use super::density::{ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// Defaults with `mu / kappa = 0.25` as in the complex-view paper's Figure 4 and
/// `mu + kappa = 1` as the reference code's single-parameter form.
pub const DEFAULT_MU: f64 = 0.2;
/// Default bulk modulus (see [`DEFAULT_MU`]).
pub const DEFAULT_KAPPA: f64 = 0.8;

/// Neo-Hookean with shear modulus `mu` and bulk modulus `kappa`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Nh {
    /// Shear modulus.
    pub mu: f64,
    /// Bulk modulus.
    pub kappa: f64,
}

impl Default for Nh {
    fn default() -> Nh {
        Nh { mu: DEFAULT_MU, kappa: DEFAULT_KAPPA }
    }
}

impl Density for Nh {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        let Nh { mu, kappa } = *self;
        let d = x - y;
        mu * 2.0 * y / d + 0.5 * kappa * (d - 1.0) * (d - 1.0)
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let Nh { mu, kappa } = *self;
        let d = x - y;
        let i1 = 1.0 / d;
        let i2 = i1 * i1;
        let i3 = i2 * i1;
        Modifiers {
            psi: self.value(x, y),
            a1: -2.0 * mu * y * i2 + kappa * (d - 1.0),
            a2: 2.0 * mu * x * i2 - kappa * (d - 1.0),
            b1: 4.0 * mu * y * i3 + kappa,
            b2: 4.0 * mu * x * i3 + kappa,
            b3: -2.0 * mu * (x + y) * i3 - kappa,
        }
    }

    fn check(&self) -> Result<(), String> {
        super::density::positive("mu", self.mu, "must be positive")?;
        if !(self.kappa >= 0.0 && self.kappa.is_finite()) {
            return Err(format!("kappa = {} must be non-negative", self.kappa));
        }
        Ok(())
    }

    fn convex_split(&self) -> Result<ConvexSplit, String> {
        Ok(ConvexSplit::NeoHookean { mu: self.mu, kappa: self.kappa })
    }
}
