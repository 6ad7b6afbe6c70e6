//! The config's documented defaults, overrides and refusals.

use super::*;
use solvers::energy::{Bconf, EnergyKind, Sarap, Sd};
use solvers::init::TutteBoundary;
use solvers::linear::LinearSettings;
use solvers::smoothness::Projection;
use solvers::solver::LineSearchSettings;
use solvers::tasks::authalic::FoldGuard;

const AUTH: &str = "name = \"a\"\ntask = \"authalic\"\ndatasets = [\"bumpy_1k\"]\nsolvers = [\"sem\", \"aem-cg\"]\n";

#[test]
fn smoothness_is_an_energy_option() {
    let c = parse(&format!(
        "{MIN}[energy.sd]\nsmoothness = 0.25\n[energy.nh]\nsmoothness = 0.5\nsmoothness_projection = \"numeric\"\n"
    ))
    .unwrap();
    assert_eq!(c.smoothness_for("sd"), Some((0.25, Projection::Analytic)));
    assert_eq!(c.smoothness_for("nh"), Some((0.5, Projection::Numeric)));
    assert_eq!(c.smoothness_for("bconf"), None);
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&format!("{MIN}[energy.sd]\nsmoothness = -1.0\n")).contains("must be non-negative"));
    assert!(err(&format!("{MIN}[energy.sd]\nsmoothness_projection = \"numeric\"\n")).contains("needs smoothness"));
}

/// exp-SD starts from the SD minimum unless its table asks for the Tutte map; another energy
/// may ask for that start, SD itself and the other tasks may not.
#[test]
fn the_start_is_an_energy_option_with_exp_sd_chained_by_default() {
    use solvers::tasks::param::ParamStart;
    let start = |c: &Config, e: &str| match c.run_settings(e).unwrap() {
        crate::plan::RunSettings::Param { settings, .. } => settings.start,
        other => panic!("{other:?}"),
    };
    let both = MIN.replace("[\"sd\"]", "[\"sd\", \"exp-sd\", \"nh\"]");
    let c = parse(&both).unwrap();
    assert_eq!(
        [start(&c, "sd"), start(&c, "exp-sd"), start(&c, "nh")],
        [ParamStart::Tutte, ParamStart::SdMinimum, ParamStart::Tutte]
    );
    let c = parse(&format!("{both}[energy.exp-sd]\nstart = \"tutte\"\n[energy.nh]\nstart = \"sd-minimum\"\n")).unwrap();
    assert_eq!([start(&c, "exp-sd"), start(&c, "nh")], [ParamStart::Tutte, ParamStart::SdMinimum]);
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&format!("{MIN}[energy.sd]\nstart = \"sd-minimum\"\n")).contains("at its own minimum"));
    assert!(err(&format!("{MIN}[energy.sd]\nstart = \"rest\"\n")).contains("unknown variant `rest`"));
    let def = format!("task = \"deform\"\n{MIN}");
    assert!(err(&format!("{def}[energy.sd]\nstart = \"tutte\"\n")).contains("start applies to the param task only"));
}

#[test]
fn timeouts_parse_with_units() {
    let t = |v: &str| parse(&format!("timeout = \"{v}\"\n{MIN}")).map(|c| c.timeout_secs().unwrap());
    assert_eq!(t("90s").unwrap(), Some(90.0));
    assert_eq!(t("10m").unwrap(), Some(600.0));
    assert_eq!(t("1.5h").unwrap(), Some(5400.0));
    assert_eq!(t("30").unwrap(), Some(30.0));
    assert!(format!("{:#}", t("10d").unwrap_err()).contains("unknown unit 'd'"));
    assert!(format!("{:#}", t("-1m").unwrap_err()).contains("not a positive duration"));
    assert_eq!(parse(MIN).unwrap().timeout_secs().unwrap(), None);
}

/// Found by the config fuzz target: a timeout that f64 holds but a run's deadline
/// (`Instant::now() + timeout`) does not panicked in the runner.
#[test]
fn huge_timeouts_are_config_errors() {
    let t = |v: &str| parse(&format!("timeout = \"{v}\"\n{MIN}")).map(|c| c.timeout_secs().unwrap());
    let huge = format!("1{}", "0".repeat(300));
    for v in [format!("{huge}s"), format!("{huge}{}h", "0".repeat(6)), "1000000001".into()] {
        assert!(format!("{:#}", t(&v).unwrap_err()).contains("is too long"), "{v}");
    }
    assert_eq!(t("1000000000").unwrap(), Some(1e9));
}

#[test]
fn authalic_configs_default_to_the_papers_protocol_and_reject_newton_sections() {
    let c = parse(AUTH).unwrap();
    assert_eq!(c.energy_names(), ["authalic"]);
    let s = c.authalic_settings();
    assert_eq!(s, AuthalicSettings::default());
    assert_eq!((s.stop.max_iters, s.stop.grad_tol, s.stop.energy_decrease_tol), (100, 0.0, 0.0));
    let c = parse(&format!(
        "{AUTH}[stop]\nmax_iters = 7\n[authalic]\nalpha0 = 0.5\nfold_guard = \"all\"\nsem_stop_on_increase = true\n"
    ))
    .unwrap();
    let s = c.authalic_settings();
    assert_eq!((s.stop.max_iters, s.alpha0, s.fold_guard, s.sem_stop_on_increase), (7, 0.5, FoldGuard::All, true));
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&AUTH.replace("\"aem-cg\"", "\"kp-newton\"")).contains("'kp-newton' is a param/deform solver"));
    assert!(err(&format!("{AUTH}energies = [\"sd\"]\n")).contains("one energy 'authalic'"));
    assert!(err(&format!("{AUTH}[line_search]\narmijo_c = 0.1\n")).contains("[line_search] does not apply"));
    assert!(err(&format!("{AUTH}[authalic]\nalpha0 = -1.0\n")).contains("alpha0 = -1"));
    assert!(err(&format!("{AUTH}[authalic]\nfold_guard = \"some\"\n")).contains("unknown variant"));
    assert!(err(&format!("{AUTH}[authalic]\nalpha = 1.0\n")).contains("unknown field `alpha`"));
    assert!(parse(&format!("{AUTH}energies = [\"authalic\"]\n")).is_ok());
}

#[test]
fn a_solver_of_another_task_is_named_as_such() {
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    let e = err(&MIN.replace("\"kp-newton\"", "\"sem\""));
    assert!(e.contains("'sem' is an authalic solver") && e.contains("task = \"authalic\""), "{e}");
    assert!(err(&MIN.replace("\"kp-newton\"", "\"sem2\"")).contains("unknown solver 'sem2'"));
    let e = err(&AUTH.replace("\"sem\"", "\"cm\""));
    assert!(e.contains("'cm' is a param/deform solver"), "{e}");
}

#[test]
fn threads_per_run_is_bounded_by_the_cores() {
    assert!(check_threads_per_run(None, 2).is_ok());
    assert!(check_threads_per_run(Some(8), 2).is_ok());
    let e = format!("{:#}", check_threads_per_run(Some(9), 2).unwrap_err());
    assert!(e.contains("threads_per_run = 9 is more than 4 x the 2 cores") && e.contains("(8)"), "{e}");
    assert!(format!("{:#}", check_threads_per_run(Some(0), 2).unwrap_err()).contains("at least 1"));
    let e = format!("{:#}", parse(&format!("threads_per_run = 100000\n{MIN}")).unwrap_err());
    assert!(e.contains("threads_per_run = 100000 is more than"), "{e}");
}

#[test]
fn jobs_are_bounded_like_threads_per_run() {
    assert!(check_jobs(None, 2).is_ok() && check_jobs(Some(1), 2).is_ok() && check_jobs(Some(8), 2).is_ok());
    for (jobs, want) in [(9, "--jobs 9 is more than 4 x the 2 cores"), (usize::MAX, "is more than 4 x the 2 cores")] {
        let e = format!("{:#}", check_jobs(Some(jobs), 2).unwrap_err());
        assert!(e.contains(want) && e.contains("(8)"), "{e}");
    }
    assert!(format!("{:#}", check_jobs(Some(0), 2).unwrap_err()).contains("at least 1"));
    assert!(check_jobs(Some(usize::MAX), usize::MAX).is_ok(), "no overflow");
}

#[test]
fn repeated_energies_solvers_and_datasets_are_refused() {
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&MIN.replace("[\"sd\"]", "[\"sd\", \"nh\", \"sd\"]")).contains("energies: 'sd' appears twice"));
    assert!(err(&MIN.replace("[\"kp-newton\"]", "[\"kp-newton\", \"kp-newton\"]"))
        .contains("solvers: 'kp-newton' appears twice"));
    assert!(err(&MIN.replace("[\"bumpy_1k\"]", "[\"bumpy_1k\", \"bumpy_1k\"]"))
        .contains("datasets: 'bumpy_1k' appears twice"));
    let two = "[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n";
    assert!(err(&format!("{MIN}{two}{two}")).contains("[[dataset]] name: 'm' appears twice"));
}

#[test]
fn inline_dataset_names_must_be_file_name_safe() {
    let err = |name: &str| {
        let t = format!("{MIN}[[dataset]]\nname = {name:?}\npath = \"m.obj\"\n");
        format!("{:#}", parse(&t).unwrap_err())
    };
    for (name, why) in [
        ("../../ESCAPED", "path separator"),
        ("/abs/x", "path separator"),
        ("a/b", "path separator"),
        ("a\nb", "U+000A"),
        ("", "is empty"),
        ("..", "'..'"),
    ] {
        let e = err(name);
        assert!(e.contains("[[dataset]]") && e.contains("dataset name") && e.contains(why), "{name:?}: {e}");
    }
}

#[test]
fn handles_on_a_param_dataset_are_refused_not_ignored() {
    let t = format!("{MIN}[[dataset]]\nname = \"m\"\npath = \"m.obj\"\nhandles_rule = \"stretch\"\n");
    let e = format!("{:#}", parse(&t).unwrap_err());
    assert!(e.contains("'m': handles apply only to task = \"deform\"") && e.contains("task is param"), "{e}");
    let deform = t.replace("name = \"t\"", "name = \"t\"\ntask = \"deform\"");
    assert!(parse(&deform).is_ok());
}

fn parse(text: &str) -> Result<Config> {
    let c: Config = toml::from_str(text)?;
    c.check()?;
    Ok(c)
}

const MIN: &str = "name = \"t\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n";

#[test]
fn minimal_config_gets_the_documented_defaults() {
    let c = parse(MIN).unwrap();
    assert_eq!(c.task, Task::Param);
    let s = c.param_settings(&EnergyKind::Sd(Sd));
    assert_eq!(s.solver.stop.grad_tol, 1e-3);
    assert_eq!(s.solver.stop.max_iters, 1000);
    assert_eq!(s.solver.stop.energy_decrease_tol, 0.0);
    assert_eq!(c.param_settings(&EnergyKind::Sarap(Sarap)).solver.stop.energy_decrease_tol, 1e-8);
    assert_eq!(s.solver.line_search, LineSearchSettings::default());
    assert_eq!(
        s.solver.linear,
        LinearSettings { tikhonov: 1e-10, jacobi: true, ordering: solvers::linear::ordering::Ordering::Metis }
    );
    assert_eq!(s.tutte_boundary, TutteBoundary::Uniform);
    assert_eq!(s.scaling_jump, 0.1);
}

#[test]
fn overrides_apply() {
    let text = format!(
        "{MIN}[stop]\nmax_iters = 7\n[init]\ntutte_boundary = \"arclength\"\n[energy.bconf]\nk = 0.5\n[line_search]\narmijo_c = 0.1\n"
    );
    let c = parse(&text).unwrap();
    let s = c.param_settings(&EnergyKind::Sd(Sd));
    assert_eq!(s.solver.stop.max_iters, 7);
    assert_eq!(s.solver.line_search.armijo_c, 0.1);
    assert_eq!(s.tutte_boundary, TutteBoundary::Arclength);
    assert_eq!(c.energy_kind("bconf").unwrap(), EnergyKind::Bconf(Bconf { k: 0.5 }));
}

#[test]
fn bad_configs_name_what_is_wrong() {
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&format!("{MIN}colour = 3\n")).contains("unknown field `colour`"));
    assert!(err(&format!("{MIN}[stop]\ngrad_tol = 1e-3\nmax_iter = 3\n")).contains("max_iter"));
    assert!(err(&MIN.replace("kp-newton", "kp-newtonn")).contains("unknown solver 'kp-newtonn'"));
    assert!(err(&MIN.replace("\"sd\"", "\"arap\"")).contains("unknown energy 'arap'"));
    assert!(
        err(&format!("{MIN}[energy.sd]\nk = 1.0\n")).contains("[energy.sd] unknown field `k`: sd has no parameters")
    );
    let e = err(&format!("{MIN}[energy.nh]\nk = 1.0\n"));
    assert!(e.contains("[energy.nh] unknown field `k`, expected `mu` or `kappa`"), "{e}");
    assert!(err(&format!("{MIN}[energy.nh]\nsmoothness = \"x\"\n")).contains("[energy.nh] invalid type"));
    assert!(err(&format!("{MIN}[energy.bconf]\nk = -1.0\n")).contains("k = -1"));
    assert!(err(&format!("{MIN}[energy.foo]\nk = 1.0\n")).contains("[energy.foo]: unknown energy"));
    assert!(err(&format!("{MIN}[line_search]\nshrink = 1.5\n")).contains("shrink"));
    assert!(err(&MIN.replace("[\"bumpy_1k\"]", "[]")).contains("no datasets"));
    assert!(err(&format!("{MIN}[deform]\nlambda = 1.0\n")).contains("only to task = \"deform\""));
    let def = format!("task = \"deform\"\n{MIN}");
    assert!(err(&format!("{def}[deform]\nlambda = 0.0\n")).contains("lambda = 0 must be positive"));
    assert!(err(&format!("{def}[init]\nscaling_jump = 0.2\n")).contains("[init] does not apply to task deform"));
    let c = parse(&format!("{def}[deform]\nlambda = 50.0\n")).unwrap();
    let s = c.deform_settings();
    assert_eq!((s.lambda, s.solver.stop.energy_decrease_tol, s.solver.stop.grad_tol), (50.0, 0.0, 1e-6));
    assert_eq!(parse(&def).unwrap().deform_settings().lambda, solvers::tasks::deform::DEFAULT_LAMBDA);
    let inline = "[[dataset]]\nname = \"x\"\npath = \"x.obj\"\nhandles = \"x.json\"\nhandles_rule = \"twist\"\n";
    assert!(err(&format!("{def}{inline}")).contains("not both"));
    assert!(err(&format!("{MIN}[authalic]\nalpha0 = 1.0\n")).contains("only to task = \"authalic\""));
    assert!(err(&format!("{MIN}[stop]\ngrad_tol = \"x\"\n")).contains("invalid type"));
}

#[test]
fn solver_sections_are_passed_through_as_given() {
    let c = parse(&format!("{MIN}[solver.slim]\nclamp_weights = true\n")).unwrap();
    assert_eq!(c.solver["slim"].get("clamp_weights").and_then(|v| v.as_bool()), Some(true));
    // the energy's settings carry none: each run gets its solver's own (`RunSettings::for_solver`)
    assert_eq!(c.param_settings(&EnergyKind::Sd(Sd)).solver.options, Default::default());
    assert_eq!(c.deform_settings().solver.options, Default::default());
    // an empty section is allowed, for a solver the config does not run too
    assert!(parse(&format!("{MIN}[solver.cm]\n")).is_ok());
}

/// Each section is read by its solver's entry (its keys, its checks) when the config is
/// read: the messages name the section and the key.
#[test]
fn solver_sections_are_checked_by_their_solver() {
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(parse(&format!("{MIN}[solver.pn-trust-region]\ntau = 0.05\n")).is_ok());
    for bad in ["0.0", "-1.0", "nan", "inf"] {
        let e = err(&format!("{MIN}[solver.pn-trust-region]\ntau = {bad}\n"));
        assert!(e.contains("[solver.pn-trust-region] tau = ") && e.contains("must be a positive number"), "{e}");
    }
    let e = err(&format!("{MIN}[solver.fp-trust-region-6x6]\ntau = 0.0\n"));
    assert!(e.contains("[solver.fp-trust-region-6x6] tau = ") && e.contains("must be a positive number"), "{e}");
    let e = err(&format!("{MIN}[solver.kp-newton]\ntau = 0.05\n"));
    assert!(e.contains("[solver.kp-newton] unknown field `tau`, there are no fields"), "{e}");
    let e = err(&format!("{MIN}[solver.slim]\ntau = 0.05\n"));
    assert!(e.contains("[solver.slim] unknown field `tau`, expected `clamp_weights`"), "{e}");
    assert!(parse(&format!("{MIN}[solver.kp-newton-cg]\neta_max = 0.5\nmax_cg_iters = 40\n")).is_ok());
    let e = err(&format!("{MIN}[solver.kp-newton-cg-laplacian]\neta_max = 0.5\n"));
    assert!(e.contains("[solver.kp-newton-cg-laplacian] unknown field `eta_max`"), "{e}");
    for bad in ["0.0", "1.0", "-0.5", "nan"] {
        let e = err(&format!("{MIN}[solver.kp-newton-cg]\neta_max = {bad}\n"));
        assert!(e.contains("[solver.kp-newton-cg] eta_max = ") && e.contains("must be in (0, 1)"), "{e}");
    }
    let e = err(&format!("{MIN}[solver.kp-newton-cg]\nmax_cg_iters = 0\n"));
    assert!(e.contains("max_cg_iters = 0: it must be at least 1"), "{e}");
}

#[test]
fn a_solver_section_for_an_unknown_solver_or_option_is_an_error_naming_it() {
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    let e = err(&format!("{MIN}[solver.slimm]\nclamp_weights = true\n"));
    assert!(e.contains("[solver.slimm]: unknown solver 'slimm' (known: kp-newton, "), "{e}");
    let e = err(&format!("{MIN}[solver.cm]\nclamp_weights = true\n"));
    assert!(e.contains("[solver.cm] unknown field `clamp_weights`, there are no fields"), "{e}");
    let e = err(&format!("{MIN}[solver.slim]\nclamp = true\n"));
    assert!(e.contains("unknown field `clamp`") && e.contains("clamp_weights"), "{e}");
    let e = err(&format!("{MIN}[solver.slim]\nclamp_weights = 1\n"));
    assert!(e.contains("invalid type"), "{e}");
    // a solver of the other task
    let e = err(&format!("{AUTH}[solver.slim]\nclamp_weights = true\n"));
    assert!(e.contains("[solver.slim]: 'slim' is a param/deform solver"), "{e}");
    let e = err(&format!("{AUTH}[solver.sem]\nclamp_weights = true\n"));
    assert!(e.contains("[solver.sem] unknown field `clamp_weights`, there are no fields"), "{e}");
}

/// `[external.<name>]` declares a solver outside the catalogue: `solvers` may name it, with
/// the task it declares; it cannot take a catalogue name or a `[solver.<name>]` table.
#[test]
fn external_solvers_are_declared_checked_and_named_like_the_others() {
    let peer = "[external.peer]\ncommand = [\"python3\", \"peer.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n";
    let base = "name = \"t\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\n";
    let c = parse(&format!("{base}solvers = [\"kp-newton\", \"peer\"]\n{peer}")).unwrap();
    assert_eq!(c.external["peer"].command, ["python3", "peer.py"]);
    let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
    assert!(err(&format!("{base}solvers = [\"peerx\"]\n{peer}"))
        .contains("a solver outside the catalogue is declared in [external.peerx]"));
    assert!(err(&format!("task = \"deform\"\n{base}solvers = [\"peer\"]\n{peer}"))
        .contains("[external.peer] solves param (its tasks), not this config's task deform"));
    assert!(err(&format!("{base}solvers = [\"slim\"]\n{}", peer.replace("external.peer", "external.slim")))
        .contains("[external.slim]: 'slim' is a solver of the catalogue"));
    assert!(err(&format!("{base}solvers = [\"peer\"]\n{peer}[solver.peer]\nx = 1\n"))
        .contains("[solver.peer]: peer is an external solver; its settings are in [external.peer]"));
    assert!(err(&format!("{base}solvers = [\"peer\"]\n{}", peer.replace("external.peer", "external.\"a/b\"")))
        .contains("contains a path separator"));
}
