//! Symmetric ARAP `(sigma1 - 1)^2 + (1/sigma2 - 1)^2` (Poranne and Lipman), Table 1/2.
//!
//! The density is not differentiable in `f_zbar` at conformal maps (`y = 0`), where
//! `alpha2 ~ y^-1/2`; the modifiers are evaluated with `y` floored at `Y_FLOOR * x` so the
//! gradient `2 alpha2 f_zbar` stays finite (it tends to a finite limit).

use super::density::{from_singular_values, ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// The modifiers use `y` floored at `Y_FLOOR * x`, so `alpha2` stays finite at conformal maps.
pub const Y_FLOOR: f64 = 1e-24;

/// Symmetric ARAP; no parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sarap;

impl Density for Sarap {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        let (a, b) = (x.sqrt(), y.sqrt());
        let s1 = a + b;
        let s2 = a - b;
        (s1 - 1.0).powi(2) + (1.0 / s2 - 1.0).powi(2)
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let psi = self.value(x, y);
        let y = y.max(Y_FLOOR * x);
        let (a, b) = (x.sqrt(), y.sqrt());
        let u = a + b;
        let v = a - b;
        let iv = 1.0 / v;
        let (iv2, iv3) = (iv * iv, iv * iv * iv);
        let hu = 2.0 * (u - 1.0);
        let hv = 2.0 * (iv2 - iv3);
        let huu = 2.0;
        let hvv = 6.0 * iv2 * iv2 - 4.0 * iv3;
        from_singular_values(x, y, psi, [hu, hv, huu, hvv, 0.0])
    }

    /// `(1/v - 1)^2` is concave for `v > 1.5`.
    fn convex_split(&self) -> Result<ConvexSplit, String> {
        Ok(ConvexSplit::Sarap)
    }

    /// Its gradient indicator fails near conformal maps (complex-view paper, Section 6.1):
    /// the `param` task stops it on an energy decrease below `1e-8` (docs/src/design/numerics.md).
    fn energy_decrease_tol(&self) -> f64 {
        1e-8
    }

    /// Not differentiable in `f_zbar` at conformal maps: its gradient need not vanish at a
    /// minimum where an element is conformal.
    fn smooth(&self) -> bool {
        false
    }
}
