//! What an energy's file implements ([`Density`]) and what it returns: the density's value
//! and modifiers, its convex-concave split for CM, and the helpers the energies share.

/// Density value and its first and second derivatives in `(x, y)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Modifiers {
    /// `psi`, the density's value.
    pub psi: f64,
    /// `alpha1 = dpsi/dx`.
    pub a1: f64,
    /// `alpha2 = dpsi/dy`.
    pub a2: f64,
    /// `beta1 = d2psi/dx2`.
    pub b1: f64,
    /// `beta2 = d2psi/dy2`.
    pub b2: f64,
    /// `beta3 = d2psi/dxdy`.
    pub b3: f64,
}

/// What an energy's file implements: its parameters (a serde type with
/// `#[serde(default, deny_unknown_fields)]` whose `Default` is the documented defaults), its
/// density and what the solvers need to know of it. [`EnergyKind`](super::EnergyKind) calls these on the
/// domain `x > y` only.
pub trait Density {
    /// `psi(x, y)`.
    fn value(&self, x: f64, y: f64) -> f64;

    /// `psi` and its modifiers (Table 2).
    fn modifiers(&self, x: f64, y: f64) -> Modifiers;

    /// The parameters' ranges: `Err("<key> = <value> must ...")`.
    fn check(&self) -> Result<(), String> {
        Ok(())
    }

    /// The convex-concave split of `h(sigma1, sigma2)` CM majorizes with, or why none is
    /// defined for these parameters.
    fn convex_split(&self) -> Result<ConvexSplit, String>;

    /// The coefficient `c` of a Dirichlet part `c |J|_F^2 = 2c (x + y)`, the quadratic part
    /// the constant proxy (`solver::proxy`) is the Hessian of; `None` without one (an
    /// exponential, a part in one singular value only, no `|J|^2` term).
    fn dirichlet_part(&self) -> Option<f64> {
        None
    }

    /// The smallest factor `s` that makes the element's `K` PSD when the map is scaled by
    /// `s`, for the energies where only `2 a1` can be negative (Section 4.2); `None`: the
    /// global scaling does not apply.
    fn psd_scale(&self, _x: f64, _y: f64) -> Option<f64> {
        None
    }

    /// The energy's own stop rule on a small relative energy decrease (0: none).
    fn energy_decrease_tol(&self) -> f64 {
        0.0
    }

    /// Whether the density is differentiable on its whole domain `x > y`, so that the
    /// gradient vanishes at a minimum (SARAP's is not at conformal maps, `y = 0`).
    fn smooth(&self) -> bool {
        true
    }
}

/// The convex-concave split of an energy `h(sigma1, sigma2)` that CM uses (complex-view paper,
/// Section 5, Appendix C).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConvexSplit {
    /// `h(sigma1, sigma2)` is convex: only the cone terms are clamped.
    Convex,
    /// SARAP: `(1/v - 1)^2` is concave for `v > 1.5`, its concave part moves to `h-`.
    Sarap,
    /// Neo-Hookean with the `(||J||_F, det J)` composition.
    NeoHookean {
        /// Shear modulus.
        mu: f64,
        /// Bulk modulus.
        kappa: f64,
    },
}

/// `Ok` when `v` is positive and finite, else `"<key> = <v> <why>"`.
pub(crate) fn positive(key: &str, v: f64, why: &str) -> Result<(), String> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key} = {v} {why}"))
    }
}

/// Modifiers of a density `h(sigma1, sigma2)` of the signed singular values
/// `sigma1 = sqrt(x) + sqrt(y)`, `sigma2 = sqrt(x) - sqrt(y)` from the partial derivatives of
/// `h` (complex-view paper, Appendix C; its `alpha2` denominator is `|f_zbar|`).
/// `hd = (h_u, h_v, h_uu, h_vv, h_uv)`.
#[inline]
pub(crate) fn from_singular_values(x: f64, y: f64, psi: f64, hd: [f64; 5]) -> Modifiers {
    let [hu, hv, huu, hvv, huv] = hd;
    let a = x.sqrt();
    let b = y.sqrt();
    Modifiers {
        psi,
        a1: (hu + hv) / (2.0 * a),
        a2: (hu - hv) / (2.0 * b),
        b1: ((huu + hvv + 2.0 * huv) * a - (hu + hv)) / (4.0 * a * a * a),
        b2: ((huu + hvv - 2.0 * huv) * b - (hu - hv)) / (4.0 * b * b * b),
        b3: (huu - hvv) / (4.0 * a * b),
    }
}
