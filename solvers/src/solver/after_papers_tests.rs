//! The solvers that came after the three papers against `kp-newton`: each reaches
//! KP's minimum without a flip, on generated and shared meshes, in `param` and `deform`.

use crate::energy::{EnergyKind, Nh, Sd};
use crate::generate::{generate, generated_handles};
use crate::mesh::Mesh;
use crate::solver::observer::{IterationRecord, Recorder};
use crate::solver::outcome::Outcome;
use crate::solver::stop::StopSettings;
use crate::tasks::deform::{solve_deform, DeformSettings};
use crate::tasks::param::{solve_param, ParamSettings};
use crate::test_support::shared_mesh;

/// The solvers after the papers that run on the Newton driver or a driver of their own.
const AFTER_THE_PAPERS: [&str; 7] =
    ["pn-abs", "fp-abs-6x6", "pn-trust-region", "fp-trust-region-6x6", "lbfgs", "lbfgs-laplacian", "aqp"];

fn param(mesh: &Mesh, solver: &str, max_iters: usize) -> (Outcome, Vec<IterationRecord>) {
    let mut settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
    settings.solver.stop = StopSettings::rules_only(1e-5, 0.0, max_iters);
    let mut rec = Recorder::default();
    let out =
        solve_param(mesh, EnergyKind::Sd(Sd), solver, &settings, &mut rec).unwrap_or_else(|e| panic!("{solver}: {e}"));
    (out, rec.rows)
}

/// No flip in any row and within `1e-6` (relative) of KP's final energy, whatever its own stop
/// rule said (the harness's verdict: from the common start, `lbfgs` on cow comes within 1.3e-8
/// of KP's energy but stalls at |grad| 1.4e-4 through 20000 iterations); stopped by the cap or
/// its own convergence test, never by a failure.
fn assert_reaches(label: &str, out: &Outcome, rows: &[IterationRecord], kp: &Outcome) {
    let ended = out.stop_reason.is_converged() || out.stop_reason == crate::solver::stop::StopReason::MaxIterations;
    assert!(ended, "{label}: {:?} after {}", out.stop_reason, out.iterations);
    assert!(rows.iter().all(|r| r.flips == 0), "{label}");
    let rel = (out.final_energy - kp.final_energy).abs() / kp.final_energy;
    assert!(rel < 1e-6, "{label}: {} vs KP {} ({rel:e})", out.final_energy, kp.final_energy);
}

#[test]
fn the_solvers_after_the_papers_reach_kp_on_two_shared_meshes() {
    for name in ["bunnyhead", "cow"] {
        let Some(mesh) = shared_mesh(name) else { return };
        let (kp, _) = param(&mesh, "kp-newton", 200);
        for solver in AFTER_THE_PAPERS {
            let (out, rows) = param(&mesh, solver, 20_000);
            eprintln!(
                "{name} {solver}: {:?} {} it, grad {:e}, rel {:e}",
                out.stop_reason,
                out.iterations,
                out.grad_norm,
                (out.final_energy - kp.final_energy) / kp.final_energy
            );
            assert_reaches(&format!("{name} {solver}"), &out, &rows, &kp);
        }
    }
}

#[test]
fn abs_filtering_matches_its_numeric_check_and_is_monotone() {
    let mesh = generate("bumpy_1k").unwrap();
    let (kp, _) = param(&mesh, "kp-newton", 200);
    let (abs, rows) = param(&mesh, "pn-abs", 200);
    assert_reaches("pn-abs", &abs, &rows, &kp);
    assert!(rows.windows(2).all(|w| w[1].energy <= w[0].energy));
    let (fp, rows) = param(&mesh, "fp-abs-6x6", 200);
    assert_reaches("fp-abs-6x6", &fp, &rows, &kp);
    assert!(rows.windows(2).all(|w| w[1].energy <= w[0].energy));
}

/// The trust-region rule on a real run, filtering `K` and the element Hessian: abs first, the
/// mode and fit recorded in every row, clamping once the model fits (close to the minimum,
/// where Newton's model is good).
#[test]
fn the_trust_region_filters_record_their_modes_and_reach_kp() {
    let mesh = generate("bumpy_1k").unwrap();
    let (kp, _) = param(&mesh, "kp-newton", 200);
    for solver in ["pn-trust-region", "fp-trust-region-6x6"] {
        let (out, rows) = param(&mesh, solver, 200);
        assert_reaches(solver, &out, &rows, &kp);
        assert!(rows.windows(2).all(|w| w[1].energy <= w[0].energy), "{solver}");
        let col = |r: &IterationRecord, name: &str| r.extra_value(name).unwrap();
        let names: Vec<&str> = rows[0].extra.iter().map(|e| e.0).collect();
        assert_eq!(names, ["filter", "rho"]);
        assert!(col(&rows[0], "filter").is_nan() && col(&rows[0], "rho").is_nan());
        assert_eq!(col(&rows[1], "filter"), 1.0, "{solver}: the first system uses abs");
        let tau = crate::hessian::trust_region::DEFAULT_TAU;
        for w in rows[1..].windows(2) {
            // each row's filter follows from the previous row's fit
            let rho = col(&w[0], "rho");
            let want = if (rho - 1.0).abs() < tau { 0.0 } else { 1.0 };
            assert_eq!(col(&w[1], "filter"), want, "{solver} row {}: rho {rho}", w[1].iter);
        }
        let clamps = rows[1..].iter().filter(|r| col(r, "filter") == 0.0).count();
        assert!(clamps > 0, "{solver}: never clamped in {} iterations", out.iterations);
    }
}

#[test]
fn the_solvers_after_the_papers_bend_the_bar_to_kp_s_minimum() {
    let name = "planar_bar_2k";
    let mesh = generate(name).unwrap();
    let handles = generated_handles(name).unwrap();
    for energy in [EnergyKind::Sd(Sd), EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 })] {
        let run = |solver: &str, stop: Option<StopSettings>| {
            let mut settings = DeformSettings::default();
            if let Some(stop) = stop {
                settings.solver.stop = stop;
            }
            let mut rec = Recorder::default();
            let out = solve_deform(&mesh, &handles, None, energy, solver, &settings, &mut rec).unwrap();
            (out, rec.rows)
        };
        // The deform rule (decrease below 1e-6) stops NH, whose energy here is 4e-4, while
        // the minima still differ in the fourth digit: compare minima on the gradient.
        let stop = Some(StopSettings::rules_only(1e-7, 0.0, 2000));
        let (kp, _) = run("kp-newton", stop);
        for solver in ["pn-abs", "fp-abs-6x6", "pn-trust-region", "fp-trust-region-6x6"] {
            let (out, rows) = run(solver, stop);
            let label = format!("{solver} {energy:?}");
            assert!(out.stop_reason.is_converged(), "{label}: {:?}", out.stop_reason);
            assert!(rows.iter().all(|r| r.flips == 0), "{label}");
            assert!(rows.windows(2).all(|w| w[1].energy <= w[0].energy), "{label}");
            let rel = (out.final_energy - kp.final_energy).abs() / kp.final_energy;
            assert!(rel < 1e-6, "{label}: {} vs KP {} after {}", out.final_energy, kp.final_energy, out.iterations);
            eprintln!("{label}: {} iterations (KP {})", out.iterations, kp.iterations);
        }
    }
}

/// L-BFGS needs thousands of iterations where Newton needs 14 (the penalty's 2 lambda = 2e5
/// against an elastic energy of order 1). The Laplacian variant, whose proxy carries the
/// handles, got to KP's minimum while its proxy was twice the Hessian of SD's quadratic part;
/// with the proxy that Hessian it ends, after 8014 iterations, where the line
/// search finds no step, at |grad| 3.3e-6 (from 1.9e6) and E = 2.3148 against KP's 2.0024:
/// a stationary point above KP's minimum, what the harness's verdict calls another minimum.
/// Pinned here so that a change of the path shows.
#[test]
fn lbfgs_with_the_laplacian_bends_the_bar_to_a_stationary_point_above_kp_s() {
    let name = "planar_bar_2k";
    let mesh = generate(name).unwrap();
    let handles = generated_handles(name).unwrap();
    let mut settings = DeformSettings::default();
    settings.solver.stop = StopSettings::rules_only(1e-7, 0.0, 20_000);
    let run = |solver: &str| {
        let mut rec = Recorder::default();
        let out = solve_deform(&mesh, &handles, None, EnergyKind::Sd(Sd), solver, &settings, &mut rec).unwrap();
        (out, rec.rows)
    };
    let (kp, _) = run("kp-newton");
    let (out, rows) = run("lbfgs-laplacian");
    let label =
        format!("{:?} after {}, |grad| {:e}, E {}", out.stop_reason, out.iterations, out.grad_norm, out.final_energy);
    assert!(rows.iter().all(|r| r.flips == 0), "{label}");
    assert!(out.grad_norm < 1e-5 && out.grad_norm < 1e-11 * rows[0].grad_norm, "{label}");
    let above = (out.final_energy - kp.final_energy) / kp.final_energy;
    assert!((0.1..0.2).contains(&above), "{label} vs KP {}", kp.final_energy);
    assert!(out.iterations > 100 * kp.iterations, "{} vs KP {}", out.iterations, kp.iterations);
}
