//! End to end: KP-Newton on SD over the generated corpus and, when `MAPBENCH_MESHES` points at
//! the shared corpus, on camelhead, hilbert, bimba_5k and cow.

use solvers::energy::{EnergyKind, Sd};
use solvers::generate::generate;
use solvers::mesh::{load_obj, Mesh};
use solvers::solver::{Recorder, StopReason};
use solvers::tasks::param::{solve_param, ParamSettings};

/// Runs KP-Newton with SD and checks the invariants of docs/src/design/testing.md; returns (iters, energy, s).
fn check_sd_run(mesh: &Mesh) -> (usize, f64, f64) {
    let e = EnergyKind::Sd(Sd);
    let mut rec = Recorder::default();
    let out = solve_param(mesh, e, "kp-newton", &ParamSettings::for_energy(&e), &mut rec).unwrap();
    assert_eq!(out.stop_reason, StopReason::GradientTolerance, "{}: {:?}", mesh.source, out.stop_reason);
    assert!(out.grad_norm <= 1e-3);
    assert_eq!(rec.rows.len(), out.iterations + 1);
    assert_eq!(rec.rows[0].iter, 0);
    for w in rec.rows.windows(2) {
        assert!(w[1].energy <= w[0].energy, "{}: energy increased at {}", mesh.source, w[1].iter);
        assert_eq!(w[1].flips, 0, "{}: flip at {}", mesh.source, w[1].iter);
    }
    assert!(out.final_energy >= 2.0, "{}: SD below the isometric bound", mesh.source);
    assert_eq!(out.flips, 0);
    let t = rec.rows.last().unwrap().t_cum_s;
    (out.iterations, out.final_energy, t)
}

#[test]
fn kp_newton_sd_converges_on_generated_meshes() {
    for name in ["flat_disk_1k", "cap_2k", "bumpy_1k", "strip_thin", "short_boundary_3k", "saddle_10k", "bumpy_10k"] {
        let mesh = generate(name).unwrap();
        let (it, e, t) = check_sd_run(&mesh);
        eprintln!("{name}: {it} iterations, E = {e:.6}, {t:.2} s");
    }
}

#[test]
fn every_energy_descends_without_flips() {
    let mesh = generate("cap_2k").unwrap();
    for name in solvers::energy::ENERGY_NAMES {
        let e = EnergyKind::default_for(name).unwrap();
        let mut rec = Recorder::default();
        let out = solve_param(&mesh, e, "kp-newton", &ParamSettings::for_energy(&e), &mut rec).unwrap();
        assert!(out.stop_reason.is_converged(), "{name}: {:?}", out.stop_reason);
        for w in rec.rows.windows(2) {
            assert!(w[1].energy <= w[0].energy && w[1].flips == 0, "{name}");
        }
    }
}

#[test]
fn kp_newton_sd_on_shared_corpus() {
    let Ok(dir) = std::env::var("MAPBENCH_MESHES") else {
        eprintln!("MAPBENCH_MESHES not set: shared-corpus test skipped");
        return;
    };
    for name in ["camelhead", "hilbert", "bimba_5k", "cow"] {
        let path = std::path::Path::new(&dir).join(format!("{name}.obj"));
        let mesh = load_obj(&path).unwrap();
        let (it, e, t) = check_sd_run(&mesh);
        eprintln!("{name}: {it} iterations, E = {e:.6}, {t:.2} s");
    }
}

/// bimba's Tutte system is one whose AMD order faer leaves unpostordered: the analysis
/// postorders it, and the Tutte map is the solution of its system.
#[test]
fn the_tutte_map_of_bimba_solves() {
    let Ok(dir) = std::env::var("MAPBENCH_MESHES") else {
        eprintln!("MAPBENCH_MESHES not set: shared-corpus test skipped");
        return;
    };
    let mesh = load_obj(&std::path::Path::new(&dir).join("bimba.obj")).unwrap().normalized();
    let x = solvers::init::tutte(&mesh, solvers::init::TutteBoundary::Uniform).unwrap();
    let problem = solvers::problem::MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
    assert_eq!(problem.flips(&x), 0);
    assert!(problem.energy(&x).is_finite());
}

#[test]
fn identical_runs_are_deterministic() {
    let mesh = generate("bumpy_1k").unwrap();
    let e = EnergyKind::Sd(Sd);
    let run = || {
        let mut rec = Recorder::default();
        solve_param(&mesh, e, "kp-newton", &ParamSettings::for_energy(&e), &mut rec).unwrap();
        rec.rows.iter().map(|r| (r.energy.to_bits(), r.grad_norm.to_bits(), r.neg_eig)).collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}
