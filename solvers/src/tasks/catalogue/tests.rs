use super::*;
use crate::energy::{Bconf, Sd};
use crate::generate::generate;
use crate::solver::Recorder;
use crate::tasks::param::{solve_param, ParamSettings};

fn energies() -> impl Iterator<Item = EnergyKind> {
    ENERGY_NAMES.iter().map(|n| EnergyKind::default_for(n).unwrap())
}

/// The table of `text`.
fn table(text: &str) -> RawOptions {
    text.parse().unwrap()
}

#[test]
fn names_are_unique_and_every_entry_is_complete() {
    let mut names: Vec<_> = SOLVERS.iter().map(|s| s.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), SOLVERS.len());
    for s in SOLVERS {
        assert!(!s.tasks.is_empty() && !s.energies.is_empty(), "{}", s.name);
        assert!(!s.label.is_empty() && !s.description.is_empty(), "{}", s.name);
        assert_eq!(find(s.name).map(|e| e.name), Some(s.name));
        // the task family of its build is the tasks it lists
        let authalic = matches!(s.build, Build::Authalic(_));
        assert_eq!(s.tasks == AUTHALIC_TASKS, authalic, "{}", s.name);
    }
    let all: usize = Task::ALL.iter().map(|&t| names_for(t).len()).sum();
    assert_eq!(all, SOLVERS.iter().map(|s| s.tasks.len()).sum::<usize>());
}

#[test]
fn every_entry_builds_for_the_energies_it_lists_and_refuses_the_others_with_a_reason() {
    for s in SOLVERS {
        for task in [Task::Param, Task::Deform] {
            for e in energies() {
                let built = s.planar(task, &e, &RawOptions::new()).map(|_| ());
                if let Build::Authalic(_) = s.build {
                    assert!(!s.is_defined_for(e.name()), "{}", s.name);
                    let err = built.unwrap_err().to_string();
                    assert!(err.starts_with(&format!("'{}' is an authalic solver: task {task}", s.name)), "{err}");
                    // a wrong task is a config error, not a skipped run
                    assert_eq!(s.skip_reason(task, &e, &RawOptions::new()), None);
                } else if s.is_defined_for(e.name()) {
                    assert_eq!(built, Ok(()), "{} {e:?}", s.name);
                    assert_eq!(s.skip_reason(task, &e, &RawOptions::new()), None);
                } else {
                    let err = built.unwrap_err().to_string();
                    let want = format!("{} is not defined for {}: ", s.name, e.name());
                    assert!(err.starts_with(&want) && err.len() > want.len() + 10, "{}: {err}", s.name);
                    assert_eq!(s.skip_reason(task, &e, &RawOptions::new()), Some(err));
                }
            }
        }
        if let Build::Planar(_) = s.build {
            let err = s.planar(Task::Authalic, &EnergyKind::Sd(Sd), &RawOptions::new()).err().unwrap().to_string();
            assert!(err.starts_with(&format!("'{}' is a param/deform solver", s.name)), "{err}");
        }
    }
    // the solvers without a Newton system say so to export-system
    for name in ["lbfgs", "lbfgs-laplacian", "aqp"] {
        let err = find(name).unwrap().newton_spec(Task::Param, &EnergyKind::Sd(Sd), &RawOptions::new()).err().unwrap();
        assert!(err.to_string().contains("has no Newton system"), "{err}");
    }
    // parameters outside a solver's domain: refused with the builder's reason, a skip
    let cm = find("cm").unwrap();
    let err =
        cm.planar(Task::Param, &EnergyKind::Bconf(Bconf { k: 1.5 }), &RawOptions::new()).err().unwrap().to_string();
    assert!(err.contains("not convex"), "{err}");
    assert_eq!(cm.skip_reason(Task::Param, &EnergyKind::Bconf(Bconf { k: 1.5 }), &RawOptions::new()), Some(err));
    assert_eq!(cm.skip_reason(Task::Deform, &EnergyKind::Bconf(Bconf { k: 0.5 }), &RawOptions::new()), None);
}

#[test]
fn each_solver_reads_its_own_options_and_refuses_others() {
    let with_options = [
        ("slim", "clamp_weights"),
        ("pn-trust-region", "tau"),
        ("fp-trust-region-6x6", "tau"),
        ("kp-newton-cg", "eta_max"),
    ];
    for s in SOLVERS {
        assert_eq!(s.check_options(&RawOptions::new()), Ok(()), "{}", s.name);
        for (_, key) in with_options {
            let value = if key == "clamp_weights" { "true" } else { "0.5" };
            let read = s.check_options(&table(&format!("{key} = {value}")));
            if with_options.contains(&(s.name, key)) {
                assert_eq!(read, Ok(()), "{}", s.name);
            } else {
                let err = read.unwrap_err().to_string();
                assert!(err.starts_with(&format!("[solver.{}] unknown field `{key}`", s.name)), "{err}");
            }
        }
    }
    // each type's own checks, naming the key and the default
    let err = |name: &str, o: RawOptions| find(name).unwrap().check_options(&o).unwrap_err().to_string();
    assert_eq!(
        err("pn-trust-region", table("tau = 0.0")),
        "[solver.pn-trust-region] tau = 0: it must be a positive number (default 0.01)"
    );
    assert_eq!(
        err("kp-newton-cg", table("eta_max = 1.0")),
        "[solver.kp-newton-cg] eta_max = 1: it must be in (0, 1) (default 0.9)"
    );
    assert_eq!(
        err("kp-newton-cg", table("max_cg_iters = 0")),
        "[solver.kp-newton-cg] max_cg_iters = 0: it must be at least 1 (default 500)"
    );
    assert!(err("slim", table("clamp_weights = 1")).contains("invalid type"));
    // and a build refuses options its check refuses
    let bad = find("kp-newton-cg").unwrap().planar(Task::Param, &EnergyKind::Sd(Sd), &table("eta_max = 2.0"));
    assert!(matches!(bad.map(|_| ()), Err(SolverError::Options { name: "kp-newton-cg", .. })));
}

#[test]
fn slim_runs_outside_its_energies_only_when_the_options_opt_in() {
    let slim = find("slim").unwrap();
    assert_eq!(slim.energies, SLIM_ENERGIES);
    let clamp = table("clamp_weights = true");
    let nh = EnergyKind::default_for("nh").unwrap();
    let why = slim.skip_reason(Task::Param, &nh, &RawOptions::new()).unwrap();
    assert!(
        why.starts_with("slim is not defined for nh: its reweighting assumes the per-triangle minimum is a rotation")
            && why.ends_with("(set [solver.slim] clamp_weights = true to run it with clamped weights)"),
        "{why}"
    );
    assert_eq!(slim.skip_reason(Task::Param, &nh, &table("clamp_weights = false")), Some(why));
    for e in energies() {
        assert!(slim.planar(Task::Param, &e, &clamp).is_ok(), "{e:?}");
        assert_eq!(slim.skip_reason(Task::Deform, &e, &clamp), None);
    }
    // the option is slim's: no other solver runs outside its energies with it
    for s in SOLVERS.iter().filter(|s| s.name != "slim") {
        assert!(!(s.opt_in)(&clamp), "{}", s.name);
    }
}

/// `[solver.pn-trust-region] tau` and `[solver.fp-trust-region-6x6] tau` reach their own
/// strategy, in `K` and in the element space.
#[test]
fn each_trust_region_threshold_reaches_its_strategy() {
    for (name, space) in [("pn-trust-region", Space::K), ("fp-trust-region-6x6", Space::Element)] {
        let tr = find(name).unwrap();
        assert_eq!(tr.extra_columns, TRUST_REGION_COLUMNS);
        for (o, tau) in [(RawOptions::new(), 0.01), (table("tau = 0.5"), 0.5)] {
            let spec = tr.newton_spec(Task::Param, &EnergyKind::Sd(Sd), &o).unwrap();
            assert_eq!(spec.block.trust_region(), Some(TrustRegion { tau, space }), "{name}");
        }
    }
    // only they adapt their filter
    for s in SOLVERS.iter().filter(|s| !s.name.contains("trust-region")) {
        if let Ok(spec) = s.newton_spec(Task::Param, &EnergyKind::Sd(Sd), &RawOptions::new()) {
            assert_eq!(spec.block.trust_region(), None, "{}", s.name);
        }
    }
    // kp-newton-cg's options reach its truncated solve
    let cg = find("kp-newton-cg").unwrap().newton_spec(Task::Param, &EnergyKind::Sd(Sd), &table("max_cg_iters = 7"));
    let SystemSolve::Truncated(Preconditioner::Stiffness, o) = cg.unwrap().solve else { panic!("not truncated") };
    assert_eq!((o.max_cg_iters, o.eta_max), (7, 0.9));
}

/// The energies SLIM is declared for are exactly those where its weights need no clamping:
/// counted at the Tutte map of a generated mesh (the numbers in `SLIM_ENERGIES`' doc).
#[test]
fn slim_weights_are_clamped_outside_its_energies_only() {
    use crate::hessian::slim::clamped_weights;
    use crate::init::{tutte, TutteBoundary};
    use crate::problem::{Evaluation, MapProblem};
    let mesh = generate("bumpy_1k").unwrap().normalized();
    let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
    let mut shares = Vec::new();
    for e in energies() {
        let problem = MapProblem::new(&mesh, e).unwrap();
        let mut ev = Evaluation::default();
        problem.evaluate(&x, &mut ev).unwrap();
        let clamped: usize = ev.states.iter().map(clamped_weights).sum();
        let share = clamped as f64 / (2 * ev.states.len()) as f64;
        shares.push((e.name(), (1000.0 * share).round() / 10.0));
        assert_eq!(clamped == 0, SLIM_ENERGIES.contains(&e.name()), "{e:?}: {clamped} clamped");
    }
    assert_eq!(shares, [("sd", 0.0), ("exp-sd", 0.0), ("sarap", 0.0), ("nh", 24.2), ("barap", 3.0), ("bconf", 6.9)]);
}

#[test]
fn a_solver_of_another_task_or_no_solver_is_named_as_such() {
    let err = |n: &str, t: Task| lookup(n, t).err().unwrap().to_string();
    let newton = names_for(Task::Param).join(", ");
    assert_eq!(err("sem", Task::Param), format!("'sem' is an authalic solver: task param runs {newton} only"));
    assert_eq!(
        err("kp-newton", Task::Authalic),
        "'kp-newton' is a param/deform solver: task authalic runs sem, aem-cg, aem-cg-safe only"
    );
    assert_eq!(err("kp", Task::Deform), format!("unknown solver 'kp' (known: {newton})"));
    assert_eq!(err("sem2", Task::Authalic), "unknown authalic solver 'sem2' (known: sem, aem-cg, aem-cg-safe)");
    assert_eq!(names_for(Task::Param), names_for(Task::Deform));
    assert!(lookup("aem-cg-safe", Task::Authalic).is_ok());
}

/// The columns an entry declares are those its runs write, in order.
#[test]
fn extra_columns_are_those_the_solvers_write() {
    let mesh = generate("bumpy_1k").unwrap();
    let mut settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
    settings.solver.stop.max_iters = 1;
    for s in SOLVERS {
        let mut rec = Recorder::default();
        match s.build {
            Build::Planar(_) => {
                let e = EnergyKind::default_for(s.energies[0]).unwrap();
                solve_param(&mesh, e, s.name, &settings, &mut rec).unwrap();
            }
            Build::Authalic(_) => {
                crate::tasks::authalic::solve_authalic(&mesh, s.name, &Default::default(), &mut rec).unwrap();
            }
        }
        for row in &rec.rows {
            let names: Vec<&str> = row.extra.iter().map(|e| e.0).collect();
            assert_eq!(names, s.extra_columns, "{} row {}", s.name, row.iter);
        }
    }
    assert_eq!(find("slim").unwrap().extra_columns, ["clamped"]);
}

/// Only unprojected Newton stops at its first failed factorization; the strategies with
/// PSD blocks keep the retry with larger shifts as a safety net.
#[test]
fn only_newton_refuses_to_retry_a_failed_factorization() {
    let mut strategies = 0;
    for s in SOLVERS.iter().filter(|s| s.runs(Task::Param)) {
        let e = EnergyKind::default_for(s.energies[0]).unwrap();
        if let Ok(spec) = s.newton_spec(Task::Param, &e, &RawOptions::new()) {
            assert_eq!(spec.block.retries_failed_factorization(), s.name != "newton", "{}", s.name);
            strategies += 1;
        }
    }
    assert_eq!(strategies, SOLVERS.iter().filter(|s| s.runs(Task::Param)).count() - 3);
}
