//! The isometric energies of the complex-view paper (Table 1) as densities `psi(x, y)` of
//! `x = |f_z|^2`, `y = |f_zbar|^2`, with the modifiers of Table 2:
//! `alpha1 = dpsi/dx`, `alpha2 = dpsi/dy`, `beta1 = d2psi/dx2`, `beta2 = d2psi/dy2`,
//! `beta3 = d2psi/dxdy`.
//!
//! Every energy here is a barrier: the density is `+inf` when `det J = x - y <= 0`.

pub mod barap;
pub mod bconf;
pub mod exp_sd;
pub mod nh;
pub mod sarap;
pub mod sd;

use serde::{Deserialize, Serialize};

/// Density value and its first and second derivatives in `(x, y)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Modifiers {
    pub psi: f64,
    pub a1: f64,
    pub a2: f64,
    pub b1: f64,
    pub b2: f64,
    pub b3: f64,
}

/// An energy with its parameters. Read from a table (`name` and the parameters, the
/// defaults for those not given, [`EnergyKind::from_table`]); another energy's parameter is
/// refused.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "name", rename_all = "kebab-case", deny_unknown_fields)]
pub enum EnergyKind {
    /// Symmetric Dirichlet, half convention: `(x + y)(1 + (x - y)^-2)`, 2 at an isometry.
    Sd,
    /// `exp(s * psi_SD)` with the half SD in the exponent (reference code's convention).
    ExpSd {
        #[serde(default = "exp_sd::default_s")]
        s: f64,
    },
    /// Symmetric ARAP `(sigma1 - 1)^2 + (1/sigma2 - 1)^2`.
    Sarap,
    /// Neo-Hookean `mu 2y/(x-y) + kappa/2 (x - y - 1)^2`.
    Nh {
        #[serde(default = "nh::default_mu")]
        mu: f64,
        #[serde(default = "nh::default_kappa")]
        kappa: f64,
    },
    /// Barrier ARAP `2(x + y - 2 sqrt(x) + 1) + k (|J| + 1/|J|)`.
    Barap {
        #[serde(default = "barap::default_k")]
        k: f64,
    },
    /// Barrier conformal `y + k (|J| + 1/|J|)`.
    Bconf {
        #[serde(default = "bconf::default_k")]
        k: f64,
    },
}

/// The one energy of the `authalic` task (the name in CSVs and configs): the normalized
/// authalic energy of Liu and Yueh, not a density of `f_z`, `f_zbar` like the others.
pub const AUTHALIC_ENERGY: &str = "authalic";

/// All energy names, in the order of the paper's Table 1.
pub const ENERGY_NAMES: [&str; 6] = ["sd", "exp-sd", "sarap", "nh", "barap", "bconf"];

impl EnergyKind {
    /// The energy with its documented default parameters.
    pub fn default_for(name: &str) -> Option<EnergyKind> {
        Some(match name {
            "sd" => EnergyKind::Sd,
            "exp-sd" => EnergyKind::ExpSd { s: exp_sd::DEFAULT_S },
            "sarap" => EnergyKind::Sarap,
            "nh" => EnergyKind::Nh { mu: nh::DEFAULT_MU, kappa: nh::DEFAULT_KAPPA },
            "barap" => EnergyKind::Barap { k: barap::DEFAULT_K },
            "bconf" => EnergyKind::Bconf { k: bconf::DEFAULT_K },
            _ => return None,
        })
    }

    /// The energy `name` with the parameters of `table` (a config's `[energy.<name>]`
    /// without its smoothness keys), the defaults for the others; checked
    /// ([`EnergyKind::check`]).
    pub fn from_table(name: &str, table: &toml::Table) -> Result<EnergyKind, String> {
        let mut named = table.clone();
        named.insert("name".to_string(), toml::Value::String(name.to_string()));
        let kind = EnergyKind::deserialize(toml::Value::Table(named)).map_err(|e| e.to_string().trim().to_string())?;
        // serde lets the variants without parameters ignore any: refuse them here
        let own = toml::Value::try_from(kind).map_err(|e| e.to_string())?;
        if let Some(key) = table.keys().find(|k| own.get(k.as_str()).is_none()) {
            return Err(format!("unknown field `{key}`: {name} has no parameters"));
        }
        kind.check()?;
        Ok(kind)
    }

    pub fn name(&self) -> &'static str {
        match self {
            EnergyKind::Sd => "sd",
            EnergyKind::ExpSd { .. } => "exp-sd",
            EnergyKind::Sarap => "sarap",
            EnergyKind::Nh { .. } => "nh",
            EnergyKind::Barap { .. } => "barap",
            EnergyKind::Bconf { .. } => "bconf",
        }
    }

    /// Density value; `+inf` outside the domain `x > y` (inverted or degenerate).
    #[inline]
    pub fn value(&self, x: f64, y: f64) -> f64 {
        if !(x - y > 0.0) {
            return f64::INFINITY;
        }
        let v = match *self {
            EnergyKind::Sd => sd::value(x, y),
            EnergyKind::ExpSd { s } => exp_sd::value(x, y, s),
            EnergyKind::Sarap => sarap::value(x, y),
            EnergyKind::Nh { mu, kappa } => nh::value(x, y, mu, kappa),
            EnergyKind::Barap { k } => barap::value(x, y, k),
            EnergyKind::Bconf { k } => bconf::value(x, y, k),
        };
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    }

    /// Value and modifiers; `None` outside the domain `x > y`.
    #[inline]
    pub fn modifiers(&self, x: f64, y: f64) -> Option<Modifiers> {
        if !(x - y > 0.0) {
            return None;
        }
        Some(match *self {
            EnergyKind::Sd => sd::modifiers(x, y),
            EnergyKind::ExpSd { s } => exp_sd::modifiers(x, y, s),
            EnergyKind::Sarap => sarap::modifiers(x, y),
            EnergyKind::Nh { mu, kappa } => nh::modifiers(x, y, mu, kappa),
            EnergyKind::Barap { k } => barap::modifiers(x, y, k),
            EnergyKind::Bconf { k } => bconf::modifiers(x, y, k),
        })
    }

    /// Check parameter ranges; the message names the offending key.
    pub fn check(&self) -> Result<(), String> {
        let bad = |key: &str, v: f64, why: &str| Err(format!("energy {}: {key} = {v} {why}", self.name()));
        match *self {
            EnergyKind::ExpSd { s } if !(s > 0.0 && s.is_finite()) => bad("s", s, "must be positive"),
            EnergyKind::Nh { mu, .. } if !(mu > 0.0 && mu.is_finite()) => bad("mu", mu, "must be positive"),
            EnergyKind::Nh { kappa, .. } if !(kappa >= 0.0 && kappa.is_finite()) => {
                bad("kappa", kappa, "must be non-negative")
            }
            EnergyKind::Barap { k } | EnergyKind::Bconf { k } if !(k > 0.0 && k.is_finite()) => {
                bad("k", k, "must be positive (it weighs the barrier)")
            }
            _ => Ok(()),
        }
    }

    /// The coefficient `c` of the energy's Dirichlet part `c |J|_F^2 = 2c (x + y)`, the
    /// quadratic part the constant proxy (`solver::proxy`) is the Hessian of: `1/2` for SD
    /// (`(x + y)(1 + (x - y)^-2) = 1/2 (|J|^2 + |J^-1|^2)`), `1` for BARAP (`|J - R|^2 =
    /// 2(x + y) - 4 sqrt(x) + 2`; its barrier's `k |J|` is quadratic too, but indefinite and
    /// summed over the mesh a boundary term, the image's signed area: the proxy leaves it out
    /// as it leaves out the `|J^-1|^2` barrier). `None` for the energies without such a part:
    /// exp-SD (exponential), SARAP (quadratic in `sigma1` only), NH (no `|J|^2` term) and
    /// BCONF (`|f_zbar|^2`).
    pub fn dirichlet_part(&self) -> Option<f64> {
        match self {
            EnergyKind::Sd => Some(0.5),
            EnergyKind::Barap { .. } => Some(1.0),
            EnergyKind::ExpSd { .. } | EnergyKind::Sarap | EnergyKind::Nh { .. } | EnergyKind::Bconf { .. } => None,
        }
    }

    /// Stationary value at an isometry (`x = 1, y = 0`), used in tests and reports.
    pub fn isometry_value(&self) -> f64 {
        self.value(1.0, 0.0)
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn a_table_reads_as_its_energy_with_the_defaults_and_refuses_other_parameters() {
        let table = |t: &str| t.parse::<toml::Table>().unwrap();
        for name in ENERGY_NAMES {
            assert_eq!(EnergyKind::from_table(name, &table("")), Ok(EnergyKind::default_for(name).unwrap()));
        }
        assert_eq!(EnergyKind::from_table("nh", &table("mu = 0.5")), Ok(EnergyKind::Nh { mu: 0.5, kappa: 0.8 }));
        assert_eq!(EnergyKind::from_table("bconf", &table("k = 0.5")), Ok(EnergyKind::Bconf { k: 0.5 }));
        let err = |n: &str, t: &str| EnergyKind::from_table(n, &table(t)).unwrap_err();
        assert_eq!(err("barap", "s = 1.0"), "unknown field `s`, expected `k`");
        assert_eq!(err("sd", "k = 1.0"), "unknown field `k`: sd has no parameters");
        assert_eq!(err("exp-sd", "s = -1.0"), "energy exp-sd: s = -1 must be positive");
        assert!(err("nh", "mu = \"x\"").contains("invalid type"));
        assert!(err("sdd", "").starts_with("unknown variant `sdd`"));
    }

    /// Deterministic pseudo-random numbers for tests (64-bit LCG).
    pub struct Lcg(pub u64);
    impl Lcg {
        pub fn next_f64(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
        }
        pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next_f64()
        }
    }

    pub fn all_energies() -> Vec<EnergyKind> {
        vec![
            EnergyKind::Sd,
            EnergyKind::ExpSd { s: 0.3 },
            EnergyKind::Sarap,
            EnergyKind::Nh { mu: 0.2, kappa: 0.8 },
            EnergyKind::Barap { k: 0.1 },
            EnergyKind::Bconf { k: 0.1 },
            EnergyKind::Barap { k: 3.0 },
            EnergyKind::Bconf { k: 1.5 },
        ]
    }

    /// Random point of the domain `x > y > 0` with moderate distortion.
    pub fn random_xy(rng: &mut Lcg) -> (f64, f64) {
        let s1 = rng.range(0.3, 2.5);
        let s2 = rng.range(0.2, 1.0) * s1;
        // sigma1 = a + b, sigma2 = a - b
        let a = 0.5 * (s1 + s2);
        let b = 0.5 * (s1 - s2);
        (a * a, b * b)
    }

    #[test]
    fn modifiers_match_central_differences() {
        let mut rng = Lcg(7);
        for e in all_energies() {
            for _ in 0..200 {
                let (x, y) = random_xy(&mut rng);
                let m = e.modifiers(x, y).unwrap();
                assert!((m.psi - e.value(x, y)).abs() <= 1e-12 * m.psi.abs().max(1.0));
                let h = 1e-6 * x.min(y).max(1e-3);
                let fd = |f: &dyn Fn(f64, f64) -> f64| {
                    ((f(x + h, y) - f(x - h, y)) / (2.0 * h), (f(x, y + h) - f(x, y - h)) / (2.0 * h))
                };
                let (dx, dy) = fd(&|x, y| e.value(x, y));
                let tol = |v: f64| 1e-5 * v.abs().max(1.0);
                assert!((dx - m.a1).abs() < tol(m.a1), "{e:?} a1 {dx} vs {}", m.a1);
                assert!((dy - m.a2).abs() < tol(m.a2), "{e:?} a2 {dy} vs {}", m.a2);
                let (dxx, dxy) = fd(&|x, y| e.modifiers(x, y).unwrap().a1);
                let (_, dyy) = fd(&|x, y| e.modifiers(x, y).unwrap().a2);
                assert!((dxx - m.b1).abs() < tol(m.b1), "{e:?} b1 {dxx} vs {}", m.b1);
                assert!((dyy - m.b2).abs() < tol(m.b2), "{e:?} b2 {dyy} vs {}", m.b2);
                assert!((dxy - m.b3).abs() < tol(m.b3), "{e:?} b3 {dxy} vs {}", m.b3);
            }
        }
    }

    #[test]
    fn barrier_outside_domain() {
        for e in all_energies() {
            assert_eq!(e.value(1.0, 1.0), f64::INFINITY);
            assert_eq!(e.value(0.5, 1.0), f64::INFINITY);
            assert!(e.modifiers(1.0, 2.0).is_none());
            assert!(e.value(1.2, 0.1).is_finite());
        }
    }

    #[test]
    fn isometry_values() {
        assert_eq!(EnergyKind::Sd.isometry_value(), 2.0);
        assert_eq!(EnergyKind::Sarap.isometry_value(), 0.0);
        assert_eq!(EnergyKind::Nh { mu: 0.2, kappa: 0.8 }.isometry_value(), 0.0);
        assert!((EnergyKind::Barap { k: 0.1 }.isometry_value() - 0.2).abs() < 1e-15);
        assert!((EnergyKind::Bconf { k: 0.1 }.isometry_value() - 0.2).abs() < 1e-15);
        assert!((EnergyKind::ExpSd { s: 0.5 }.isometry_value() - 1f64.exp()).abs() < 1e-14);
    }

    #[test]
    fn sd_is_minimal_at_isometries() {
        // SD >= 2 with equality iff both singular values are 1.
        let mut rng = Lcg(3);
        for _ in 0..1000 {
            let (x, y) = random_xy(&mut rng);
            assert!(EnergyKind::Sd.value(x, y) >= 2.0);
        }
    }

    #[test]
    fn names_round_trip_and_checks() {
        for n in ENERGY_NAMES {
            let e = EnergyKind::default_for(n).unwrap();
            assert_eq!(e.name(), n);
            assert!(e.check().is_ok());
        }
        assert!(EnergyKind::default_for("arap").is_none());
        assert!(EnergyKind::Bconf { k: -1.0 }.check().unwrap_err().contains("k = -1"));
    }
}
