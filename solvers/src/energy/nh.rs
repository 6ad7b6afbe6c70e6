//! Neo-Hookean `mu/2 (||J||_F^2 / |J| - 2) + kappa/2 (|J| - 1)^2 = mu 2y/(x-y) + kappa/2 (x-y-1)^2`.

use super::Modifiers;

/// Defaults with `mu / kappa = 0.25` as in the complex-view paper's Figure 4 and
/// `mu + kappa = 1` as the reference code's single-parameter form.
pub const DEFAULT_MU: f64 = 0.2;

pub(super) fn default_mu() -> f64 {
    DEFAULT_MU
}
pub const DEFAULT_KAPPA: f64 = 0.8;

pub(super) fn default_kappa() -> f64 {
    DEFAULT_KAPPA
}

#[inline]
pub fn value(x: f64, y: f64, mu: f64, kappa: f64) -> f64 {
    let d = x - y;
    mu * 2.0 * y / d + 0.5 * kappa * (d - 1.0) * (d - 1.0)
}

#[inline]
pub fn modifiers(x: f64, y: f64, mu: f64, kappa: f64) -> Modifiers {
    let d = x - y;
    let i1 = 1.0 / d;
    let i2 = i1 * i1;
    let i3 = i2 * i1;
    Modifiers {
        psi: value(x, y, mu, kappa),
        a1: -2.0 * mu * y * i2 + kappa * (d - 1.0),
        a2: 2.0 * mu * x * i2 - kappa * (d - 1.0),
        b1: 4.0 * mu * y * i3 + kappa,
        b2: 4.0 * mu * x * i3 + kappa,
        b3: -2.0 * mu * (x + y) * i3 - kappa,
    }
}
