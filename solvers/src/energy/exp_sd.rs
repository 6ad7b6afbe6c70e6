//! Exponential symmetric Dirichlet `exp(s * psi_SD)` with the half SD in the exponent,
//! as in the complex-view reference code (libigl's `exp_factor` f equals s / 2).

use super::{sd, Modifiers};

/// Default exponent weight. Tutte initializations with slivers overflow quickly, so the
/// default is mild; set `[energy.exp-sd] s` in the config.
pub const DEFAULT_S: f64 = 0.1;

pub(super) fn default_s() -> f64 {
    DEFAULT_S
}

#[inline]
pub fn value(x: f64, y: f64, s: f64) -> f64 {
    (s * sd::value(x, y)).exp()
}

#[inline]
pub fn modifiers(x: f64, y: f64, s: f64) -> Modifiers {
    let m = sd::modifiers(x, y);
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
