//! Symmetric Dirichlet (half convention), Table 1/2 of the complex-view paper.

use super::Modifiers;

#[inline]
pub fn value(x: f64, y: f64) -> f64 {
    let d = x - y;
    (x + y) * (1.0 + 1.0 / (d * d))
}

#[inline]
pub fn modifiers(x: f64, y: f64) -> Modifiers {
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
