//! The isometric energies of the complex-view paper (Table 1) as densities `psi(x, y)` of
//! `x = |f_z|^2`, `y = |f_zbar|^2`, with the modifiers of Table 2:
//! `alpha1 = dpsi/dx`, `alpha2 = dpsi/dy`, `beta1 = d2psi/dx2`, `beta2 = d2psi/dy2`,
//! `beta3 = d2psi/dxdy`.
//!
//! Every energy here is a barrier: the density is `+inf` when `det J = x - y <= 0`.

mod density;

pub use density::{ConvexSplit, Density, Modifiers};
use serde::{Deserialize, Serialize};

/// The energies: a variant, its name in configs and CSVs, and its file's type. Adding an
/// energy is its file and one line here.
macro_rules! energies {
    ($($variant:ident($name:literal, $module:ident::$ty:ident),)*) => {
        $(pub mod $module;)*
        $(pub use $module::$ty;)*

        /// An energy with its parameters. Read from a table (`name` and the parameters, the
        /// defaults for those not given, [`EnergyKind::from_table`]); another energy's
        /// parameter is refused.
        #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(tag = "name")]
        pub enum EnergyKind {
            $(
                #[doc = concat!("The `", $name, "` energy ([`", stringify!($ty), "`]).")]
                #[serde(rename = $name)]
                $variant($ty),
            )*
        }

        /// All energy names, in the order of the paper's Table 1.
        pub const ENERGY_NAMES: &[&str] = &[$($name),*];

        impl EnergyKind {
            /// The energy with its documented default parameters.
            pub fn default_for(name: &str) -> Option<EnergyKind> {
                match name {
                    $($name => Some(EnergyKind::$variant($ty::default())),)*
                    _ => None,
                }
            }

            /// The energy's name in configs and CSVs.
            pub fn name(&self) -> &'static str {
                match self {
                    $(EnergyKind::$variant(_) => $name,)*
                }
            }

            fn density(&self) -> &dyn Density {
                match self {
                    $(EnergyKind::$variant(e) => e,)*
                }
            }

            /// Density value; `+inf` outside the domain `x > y` (inverted or degenerate).
            #[inline]
            pub fn value(&self, x: f64, y: f64) -> f64 {
                if !(x - y > 0.0) {
                    return f64::INFINITY;
                }
                let v = match self {
                    $(EnergyKind::$variant(e) => e.value(x, y),)*
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
                Some(match self {
                    $(EnergyKind::$variant(e) => e.modifiers(x, y),)*
                })
            }
        }
    };
}

energies! {
    Sd("sd", sd::Sd),
    ExpSd("exp-sd", exp_sd::ExpSd),
    Sarap("sarap", sarap::Sarap),
    Nh("nh", nh::Nh),
    Barap("barap", barap::Barap),
    Bconf("bconf", bconf::Bconf),
}

impl EnergyKind {
    /// The energy `name` with the parameters of `table` (a config's `[energy.<name>]`
    /// without its smoothness keys), the defaults for the others; checked
    /// ([`EnergyKind::check`]).
    pub fn from_table(name: &str, table: &toml::Table) -> Result<EnergyKind, String> {
        // an energy without parameters serializes as its name alone; serde would refuse a key
        // with "invalid type: map"
        let own = EnergyKind::default_for(name).and_then(|e| toml::Value::try_from(e).ok());
        if own.is_some_and(|own| own.as_table().is_some_and(|t| t.len() == 1)) {
            if let Some(key) = table.keys().next() {
                return Err(format!("unknown field `{key}`: {name} has no parameters"));
            }
        }
        let mut named = table.clone();
        named.insert("name".to_string(), toml::Value::String(name.to_string()));
        let kind = EnergyKind::deserialize(toml::Value::Table(named)).map_err(|e| e.to_string().trim().to_string())?;
        kind.check()?;
        Ok(kind)
    }

    /// Check parameter ranges; the message names the energy and the offending key.
    pub fn check(&self) -> Result<(), String> {
        self.density().check().map_err(|why| format!("energy {}: {why}", self.name()))
    }

    /// See [`Density::convex_split`].
    pub fn convex_split(&self) -> Result<ConvexSplit, String> {
        self.density().convex_split()
    }

    /// See [`Density::dirichlet_part`].
    pub fn dirichlet_part(&self) -> Option<f64> {
        self.density().dirichlet_part()
    }

    /// See [`Density::psd_scale`].
    pub fn psd_scale(&self, x: f64, y: f64) -> Option<f64> {
        self.density().psd_scale(x, y)
    }

    /// See [`Density::energy_decrease_tol`].
    pub fn energy_decrease_tol(&self) -> f64 {
        self.density().energy_decrease_tol()
    }

    /// See [`Density::smooth`].
    pub fn smooth(&self) -> bool {
        self.density().smooth()
    }

    /// The value at an isometry (`x = 1, y = 0`): the density's smallest value, so the
    /// energy's lower bound on any mesh (every density here is minimal at isometries; tested),
    /// from which the harness measures a minimum's distortion.
    pub fn isometry_value(&self) -> f64 {
        self.value(1.0, 0.0)
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
        assert_eq!(EnergyKind::from_table("nh", &table("mu = 0.5")), Ok(EnergyKind::Nh(Nh { mu: 0.5, kappa: 0.8 })));
        assert_eq!(EnergyKind::from_table("bconf", &table("k = 0.5")), Ok(EnergyKind::Bconf(Bconf { k: 0.5 })));
        let err = |n: &str, t: &str| EnergyKind::from_table(n, &table(t)).unwrap_err();
        assert_eq!(err("barap", "s = 1.0"), "unknown field `s`, expected `k`");
        assert_eq!(err("sd", "k = 1.0"), "unknown field `k`: sd has no parameters");
        assert_eq!(err("exp-sd", "s = -1.0"), "energy exp-sd: s = -1 must be positive");
        assert!(err("nh", "mu = \"x\"").contains("invalid type"));
        assert!(err("sdd", "").starts_with("unknown variant `sdd`"));
    }

    #[test]
    fn an_energy_writes_its_name_and_parameters_and_reads_back() {
        let text = |e: EnergyKind| toml::Value::try_from(e).unwrap().to_string();
        assert_eq!(text(EnergyKind::Sd(Sd)), r#"{ name = "sd" }"#);
        assert_eq!(text(EnergyKind::Nh(Nh { mu: 0.5, kappa: 1.0 })), r#"{ kappa = 1.0, mu = 0.5, name = "nh" }"#);
        for e in all_energies() {
            assert_eq!(EnergyKind::deserialize(toml::Value::try_from(e).unwrap()), Ok(e));
        }
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

    /// Every energy with its defaults, and other parameters where they change the shape
    /// (a steeper exponential, barriers past CM's convexity bounds).
    pub fn all_energies() -> Vec<EnergyKind> {
        let defaults = ENERGY_NAMES.iter().map(|n| EnergyKind::default_for(n).unwrap());
        defaults
            .chain([
                EnergyKind::ExpSd(ExpSd { s: 0.3 }),
                EnergyKind::Barap(Barap { k: 3.0 }),
                EnergyKind::Bconf(Bconf { k: 1.5 }),
            ])
            .collect()
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
        assert_eq!(EnergyKind::Sd(Sd).isometry_value(), 2.0);
        assert_eq!(EnergyKind::Sarap(Sarap).isometry_value(), 0.0);
        assert_eq!(EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 }).isometry_value(), 0.0);
        assert!((EnergyKind::Barap(Barap { k: 0.1 }).isometry_value() - 0.2).abs() < 1e-15);
        assert!((EnergyKind::Bconf(Bconf { k: 0.1 }).isometry_value() - 0.2).abs() < 1e-15);
        assert!((EnergyKind::ExpSd(ExpSd { s: 0.5 }).isometry_value() - 1f64.exp()).abs() < 1e-14);
    }

    /// The isometry value bounds every density from below, far from the isometry too (the
    /// harness's accuracy scale, `E* - E_iso`, is never negative).
    #[test]
    fn every_energy_is_smallest_at_isometries() {
        let mut rng = Lcg(11);
        for e in all_energies() {
            let lo = e.isometry_value();
            for _ in 0..20000 {
                // singular values from 1e-3 to 1e3, either order of magnitude
                let s1 = 10f64.powf(rng.range(-3.0, 3.0));
                let s2 = s1 * 10f64.powf(rng.range(-3.0, 0.0));
                let (a, b) = (0.5 * (s1 + s2), 0.5 * (s1 - s2));
                let v = e.value(a * a, b * b);
                assert!(v >= lo * (1.0 - 1e-15), "{e:?} at ({s1}, {s2}): {v} < {lo}");
            }
            // near the isometry, in every direction
            for (s1, s2) in [(1.0 + 1e-4, 1.0), (1.0, 1.0 - 1e-4), (1.0 + 1e-4, 1.0 - 1e-4), (1.0 - 1e-5, 1.0 - 2e-5)] {
                let (a, b): (f64, f64) = (0.5 * (s1 + s2), 0.5 * (s1 - s2));
                assert!(e.value(a * a, b * b) >= lo, "{e:?} at ({s1}, {s2})");
            }
        }
    }

    #[test]
    fn sd_is_minimal_at_isometries() {
        // SD >= 2 with equality iff both singular values are 1.
        let mut rng = Lcg(3);
        for _ in 0..1000 {
            let (x, y) = random_xy(&mut rng);
            assert!(EnergyKind::Sd(Sd).value(x, y) >= 2.0);
        }
    }

    #[test]
    fn names_round_trip_and_checks() {
        for n in ENERGY_NAMES {
            let e = EnergyKind::default_for(n).unwrap();
            assert_eq!(e.name(), *n);
            assert!(e.check().is_ok());
        }
        assert!(EnergyKind::default_for("arap").is_none());
        assert!(EnergyKind::Bconf(Bconf { k: -1.0 }).check().unwrap_err().contains("k = -1"));
    }
}
