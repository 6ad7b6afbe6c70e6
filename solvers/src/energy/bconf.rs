//! Barrier conformal `y + k (|J| + |J|^-1)` (complex-view paper, Section 4.1): the LSCM
//! energy plus a barrier.

use super::Modifiers;

/// The paper's experiments use k = 0.1.
pub const DEFAULT_K: f64 = 0.1;

pub(super) fn default_k() -> f64 {
    DEFAULT_K
}

#[inline]
pub fn value(x: f64, y: f64, k: f64) -> f64 {
    let d = x - y;
    y + k * (d + 1.0 / d)
}

#[inline]
pub fn modifiers(x: f64, y: f64, k: f64) -> Modifiers {
    let d = x - y;
    let i2 = 1.0 / (d * d);
    let i3 = i2 / d;
    Modifiers {
        psi: value(x, y, k),
        a1: k * (1.0 - i2),
        a2: k * i2 + 1.0 - k,
        b1: 2.0 * k * i3,
        b2: 2.0 * k * i3,
        b3: -2.0 * k * i3,
    }
}
