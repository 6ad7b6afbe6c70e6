//! The catalogue against the solvers themselves: every entry writes exactly the extra
//! columns it declares, and the tasks refuse each other's solvers by name.

use solvers::energy::{EnergyKind, Sd};
use solvers::generate::{generate, generated_handles};
use solvers::solver::{Recorder, StopSettings};
use solvers::tasks::authalic::{solve_authalic, AuthalicSettings};
use solvers::tasks::catalogue::SOLVERS;
use solvers::tasks::param::{solve_param, ParamSettings};
use solvers::tasks::Task;

#[test]
fn every_solver_writes_exactly_the_extra_columns_it_declares() {
    let disk = generate("bumpy_1k").unwrap();
    for entry in SOLVERS {
        let mut rec = Recorder::default();
        if entry.runs(Task::Authalic) {
            let stop = StopSettings { max_iters: 2, ..solvers::tasks::authalic::default_stop() };
            let settings = AuthalicSettings { stop, ..Default::default() };
            solve_authalic(&disk, entry.name, &settings, &mut rec).unwrap();
        } else {
            let mut settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
            settings.solver.stop.max_iters = 2;
            solve_param(&disk, EnergyKind::Sd(Sd), entry.name, &settings, &mut rec).unwrap();
        }
        // Unprojected newton may stop at its first failed factorization (row 0 only); every
        // solver that declares extra columns must show them on an iteration row too.
        let least = if entry.extra_columns.is_empty() { 1 } else { 2 };
        assert!(rec.rows.len() >= least, "{}", entry.name);
        for r in &rec.rows {
            let names: Vec<&str> = r.extra.iter().map(|e| e.0).collect();
            assert_eq!(names, entry.extra_columns, "{} row {}", entry.name, r.iter);
        }
    }
}

#[test]
fn param_and_deform_refuse_an_authalic_solver_by_name() {
    let e = EnergyKind::Sd(Sd);
    let disk = generate("bumpy_1k").unwrap();
    let err = solve_param(&disk, e, "sem", &ParamSettings::for_energy(&e), &mut Recorder::default()).unwrap_err();
    assert!(err.to_string().starts_with("'sem' is an authalic solver: task param runs kp-newton, "), "{err}");
    let bar = generate("planar_bar_2k").unwrap();
    let handles = generated_handles("planar_bar_2k").unwrap();
    let settings = solvers::tasks::deform::DeformSettings::default();
    let err =
        solvers::tasks::deform::solve_deform(&bar, &handles, None, e, "aem-cg", &settings, &mut Recorder::default())
            .unwrap_err();
    assert!(err.to_string().starts_with("'aem-cg' is an authalic solver: task deform runs "), "{err}");
    let err = solve_param(&disk, e, "kp", &ParamSettings::for_energy(&e), &mut Recorder::default()).unwrap_err();
    assert!(err.to_string().starts_with("unknown solver 'kp' (known: kp-newton, "), "{err}");
}
