//! Barrier ARAP `2(x + y - 2 sqrt(x) + 1) + k (|J| + |J|^-1)` (complex-view paper, Section 4.1).

use super::density::{ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// The paper's experiments use k = 0.1.
pub const DEFAULT_K: f64 = 0.1;

/// Barrier ARAP with the barrier weight `k`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Barap {
    /// The barrier's weight.
    pub k: f64,
}

impl Default for Barap {
    fn default() -> Barap {
        Barap { k: DEFAULT_K }
    }
}

impl Density for Barap {
    #[inline]
    fn value(&self, x: f64, y: f64) -> f64 {
        let d = x - y;
        2.0 * (x + y - 2.0 * x.sqrt() + 1.0) + self.k * (d + 1.0 / d)
    }

    #[inline]
    fn modifiers(&self, x: f64, y: f64) -> Modifiers {
        let k = self.k;
        let d = x - y;
        let i2 = 1.0 / (d * d);
        let i3 = i2 / d;
        let sx = x.sqrt();
        Modifiers {
            psi: self.value(x, y),
            a1: k * (1.0 - i2) + 2.0 * (1.0 - 1.0 / sx),
            a2: k * i2 + 2.0 - k,
            b1: 2.0 * k * i3 + 1.0 / (x * sx),
            b2: 2.0 * k * i3,
            b3: -2.0 * k * i3,
        }
    }

    fn check(&self) -> Result<(), String> {
        super::density::positive("k", self.k, "must be positive (it weighs the barrier)")
    }

    /// `h = (u - 1)^2 + (v - 1)^2 + k (uv + 1/(uv))` is convex in `(u, v)` iff `k <= 2`.
    fn convex_split(&self) -> Result<ConvexSplit, String> {
        if self.k <= 2.0 {
            return Ok(ConvexSplit::Convex);
        }
        Err(format!("barap with k = {} is not convex in the singular values (needs k <= 2)", self.k))
    }

    /// `|J - R|^2 = 2(x + y) - 4 sqrt(x) + 2`; the barrier's `k |J|` is quadratic too, but
    /// indefinite and summed over the mesh a boundary term, the image's signed area: the
    /// proxy leaves it out as it leaves out the `|J^-1|^2` barrier.
    fn dirichlet_part(&self) -> Option<f64> {
        Some(1.0)
    }

    /// `a1(s) >= 0  <=>  (k + 2) s^4 - 2 x^-1/2 s^3 - k d^-2 >= 0`: one positive root.
    fn psd_scale(&self, x: f64, y: f64) -> Option<f64> {
        Some(scale_root(self.k, x, x - y))
    }
}

/// The unique positive root of `p(s) = (k + 2) s^4 - 2 x^-1/2 s^3 - k d^-2` (p(0) < 0, and p
/// has a single positive critical point), by bracketing and bisection-safeguarded Newton.
fn scale_root(k: f64, x: f64, d: f64) -> f64 {
    let a = k + 2.0;
    let b = 2.0 / x.sqrt();
    let c = k / (d * d);
    let p = |s: f64| ((a * s - b) * s * s) * s - c;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while p(hi) < 0.0 {
        lo = hi;
        hi *= 2.0;
    }
    let mut s = hi;
    for _ in 0..200 {
        let ps = p(s);
        if ps > 0.0 {
            hi = s;
        } else {
            lo = s;
        }
        let dp = (4.0 * a * s - 3.0 * b) * s * s;
        let mut next = s - ps / dp;
        if !(next > lo && next < hi && next.is_finite()) {
            next = 0.5 * (lo + hi);
        }
        if (next - s).abs() <= 1e-15 * s {
            return next;
        }
        s = next;
    }
    s
}
