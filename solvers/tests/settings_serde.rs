//! The settings types deserialize straight from config tables: an empty table is their
//! `Default`, a partial one keeps the other defaults, an unknown key is refused.

use serde::de::DeserializeOwned;
use solvers::init::TutteBoundary;
use solvers::linear::ordering::Ordering;
use solvers::linear::LinearSettings;
use solvers::smoothness::Projection;
use solvers::solver::{LineSearchSettings, StopOverrides, StopSettings};
use solvers::tasks::authalic::{AuthalicSettings, FoldGuard};
use std::fmt::Debug;

fn parse<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    toml::from_str(text).map_err(|e| e.to_string())
}

fn empty_is_default_and_unknown_keys_are_refused<T: DeserializeOwned + Default + PartialEq + Debug>() {
    let name = std::any::type_name::<T>();
    assert_eq!(parse::<T>("").unwrap(), T::default(), "{name}");
    let err = parse::<T>("bogus = 1\n").unwrap_err();
    assert!(err.contains("unknown field `bogus`"), "{name}: {err}");
}

#[test]
fn settings_tables_default_to_their_default_and_refuse_unknown_keys() {
    empty_is_default_and_unknown_keys_are_refused::<StopSettings>();
    empty_is_default_and_unknown_keys_are_refused::<StopOverrides>();
    empty_is_default_and_unknown_keys_are_refused::<LineSearchSettings>();
    empty_is_default_and_unknown_keys_are_refused::<LinearSettings>();
    empty_is_default_and_unknown_keys_are_refused::<AuthalicSettings>();
}

#[test]
fn the_defaults_are_the_documented_values() {
    let stop = StopSettings::default();
    assert_eq!((stop.grad_tol, stop.energy_decrease_tol, stop.max_iters), (1e-3, 0.0, 1000));
    let ls = LineSearchSettings::default();
    assert_eq!((ls.max_step_fraction, ls.armijo_c, ls.shrink, ls.min_step), (0.9, 0.2, 0.5, 1e-12));
    let lin = LinearSettings::default();
    assert_eq!((lin.tikhonov, lin.jacobi, lin.ordering), (1e-10, true, Ordering::Metis));
    // the paper's Table 1 protocol: 100 iterations, no tolerance stop
    let a = AuthalicSettings::default();
    assert_eq!((a.stop.grad_tol, a.stop.energy_decrease_tol, a.stop.max_iters), (0.0, 0.0, 100));
    assert_eq!((a.init_steps, a.alpha0, a.armijo_c, a.wolfe_c2), (5, 2.0, 1e-4, 0.45));
    assert_eq!((a.max_backtracks, a.fold_guard, a.sem_stop_on_increase), (30, FoldGuard::Boundary, false));
}

#[test]
fn partial_tables_keep_the_other_defaults() {
    let s: LineSearchSettings = parse("armijo_c = 0.1\n").unwrap();
    assert_eq!(s, LineSearchSettings { armijo_c: 0.1, ..Default::default() });
    let s: LinearSettings = parse("ordering = \"amd\"\njacobi = false\n").unwrap();
    assert_eq!(s, LinearSettings { ordering: Ordering::Amd, jacobi: false, ..Default::default() });
    let s: AuthalicSettings = parse("alpha0 = 0.5\nfold_guard = \"all\"\n").unwrap();
    assert_eq!(s, AuthalicSettings { alpha0: 0.5, fold_guard: FoldGuard::All, ..Default::default() });
    // [stop] is its own section, laid over the task's default, never a key of [authalic]
    assert!(parse::<AuthalicSettings>("[stop]\nmax_iters = 7\n").unwrap_err().contains("unknown field `stop`"));
    let o: StopOverrides = parse("max_iters = 7\n").unwrap();
    let base = AuthalicSettings::default().stop;
    assert_eq!(o.over(base), StopSettings { max_iters: 7, ..base });
    assert!(parse::<LinearSettings>("jacobi = 1\n").is_err(), "types are checked");
}

#[test]
fn enum_settings_take_their_kebab_case_names() {
    #[derive(serde::Deserialize)]
    struct T {
        tutte: TutteBoundary,
        projection: Projection,
        guard: FoldGuard,
    }
    let t: T = parse("tutte = \"arclength\"\nprojection = \"numeric\"\nguard = \"none\"\n").unwrap();
    assert_eq!((t.tutte, t.projection, t.guard), (TutteBoundary::Arclength, Projection::Numeric, FoldGuard::None));
    assert!(parse::<T>("tutte = \"circle\"\nprojection = \"numeric\"\nguard = \"none\"\n").is_err());
}

#[test]
fn run_settings_serialize_without_the_runtime_cache() {
    use solvers::energy::{EnergyKind, Sarap};
    let mut p = solvers::tasks::param::ParamSettings::for_energy(&EnergyKind::Sarap(Sarap));
    p.solver.analyses = Some(std::sync::Arc::new(solvers::linear::AnalysisCache::new()));
    let text = toml::to_string(&p).unwrap();
    assert!(
        text.contains("energy_decrease_tol = 0.00000001") && text.contains("tutte_boundary = \"uniform\""),
        "{text}"
    );
    assert!(!text.contains("analyses"), "{text}");
    let d = toml::to_string(&solvers::tasks::deform::DeformSettings::default()).unwrap();
    assert!(d.contains("lambda = 100000.0") && d.contains("max_iters = 1000"), "{d}");
}
