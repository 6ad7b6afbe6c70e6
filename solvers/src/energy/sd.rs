//! Symmetric Dirichlet (half convention), Table 1/2 of the complex-view paper:
//! `(x + y)(1 + (x - y)^-2)`, 2 at an isometry.

use super::density::{ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// Symmetric Dirichlet; no parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sd;

impl Density for Sd {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        let d = x - y;
        (x + y) * (1.0 + 1.0 / (d * d))
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let d = x - y;
        let i2 = 1.0 / (d * d);
        let i3 = i2 / d;
        let i4 = i2 * i2;
        Modifiers {
            psi: (x + y) * (1.0 + i2),
            a1: 1.0 - (x + 3.0 * y) * i3,
            a2: 1.0 + (3.0 * x + y) * i3,
            b1: 2.0 * (x + 5.0 * y) * i4,
            b2: 2.0 * (5.0 * x + y) * i4,
            b3: -6.0 * (x + y) * i4,
        }
    }

    fn convex_split(&self) -> Result<ConvexSplit, String> {
        Ok(ConvexSplit::Convex)
    }

    /// `(x + y)(1 + (x - y)^-2) = 1/2 (|J|^2 + |J^-1|^2)`.
    fn dirichlet_part(&self) -> Option<f64> {
        Some(0.5)
    }

    /// `a1(s) = 1 - (x + 3y)(x - y)^-3 s^-4 >= 0`.
    fn psd_scale(&self, x: f64, y: f64) -> Option<f64> {
        let d = x - y;
        Some(((x + 3.0 * y) / (d * d * d)).powf(0.25))
    }
}
