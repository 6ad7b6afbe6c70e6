//! The Hessian strategies as peers on one pipeline:
//! the invariants of docs/src/design/testing.md at the solver level.

use solvers::energy::{Barap, Bconf, EnergyKind, Nh, Sarap, Sd};
use solvers::generate::generate;
use solvers::mesh::{load_obj, Mesh};
use solvers::solver::{Outcome, Recorder};
use solvers::tasks::param::{solve_param, ParamSettings};

fn run(mesh: &Mesh, energy: EnergyKind, solver: &str) -> (Outcome, Recorder) {
    let mut rec = Recorder::default();
    let out = solve_param(mesh, energy, solver, &ParamSettings::for_energy(&energy), &mut rec)
        .unwrap_or_else(|e| panic!("{} {solver}: {e}", mesh.source));
    (out, rec)
}

/// Monotone energy, no flips, `neg_eig` from the unmodified Hessian in every row.
fn check_descent(label: &str, rec: &Recorder) {
    for w in rec.rows.windows(2) {
        assert!(w[1].energy <= w[0].energy, "{label}: energy increased at {}", w[1].iter);
        assert_eq!(w[1].flips, 0, "{label}: flip at {}", w[1].iter);
    }
}

/// Two generated meshes, plus the named shared ones when `MAPBENCH_MESHES` is set.
fn meshes(shared: &[&str]) -> Vec<Mesh> {
    let mut v = vec![generate("bumpy_1k").unwrap(), generate("cap_2k").unwrap()];
    if let Ok(dir) = std::env::var("MAPBENCH_MESHES") {
        for name in shared {
            v.push(load_obj(&std::path::Path::new(&dir).join(format!("{name}.obj"))).unwrap());
        }
    }
    v
}

#[test]
fn fp4_and_fp6_take_the_same_path() {
    // FP4 and FP6 agree to round-off per element; on the long, thin hilbert mesh that
    // round-off grows into 46 vs 48 iterations, so it is not part of this check.
    for mesh in meshes(&["bimba_5k"]) {
        for energy in [EnergyKind::Sd(Sd), EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 })] {
            let (a, ra) = run(&mesh, energy, "fp-newton-4x4");
            let (b, rb) = run(&mesh, energy, "fp-newton-6x6");
            let label = format!("{} {}", mesh.source, energy.name());
            assert!(a.stop_reason.is_converged() && b.stop_reason.is_converged(), "{label}");
            assert!(a.iterations.abs_diff(b.iterations) <= 1, "{label}: {} vs {}", a.iterations, b.iterations);
            assert!((a.final_energy - b.final_energy).abs() <= 1e-6 * b.final_energy, "{label}");
            check_descent(&label, &ra);
            check_descent(&label, &rb);
            eprintln!("{label}: fp4 {} fp6 {} iterations", a.iterations, b.iterations);
        }
    }
}

#[test]
fn cm_and_kp_are_identical_where_their_hessians_agree() {
    // docs/src/design/testing.md: CM's Hessian equals KP's for SD, BCONF (k <= 1) and BARAP (k <= 2), so the
    // runs agree iterate for iterate from the same start (the common, scaled Tutte map).
    // hilbert: long and thin, where round-off differences between KP and CM grew into
    // different iteration counts before KP used CM's arithmetic for the cone term.
    for mesh in meshes(&["bimba_5k", "hilbert"]) {
        for energy in [EnergyKind::Sd(Sd), EnergyKind::Bconf(Bconf { k: 0.1 }), EnergyKind::Barap(Barap { k: 0.1 })] {
            let (a, ra) = run(&mesh, energy, "cm");
            let (b, rb) = run(&mesh, energy, "kp-newton");
            let label = format!("{} {}", mesh.source, energy.name());
            assert_eq!(a.iterations, b.iterations, "{label}");
            assert_eq!(a.stop_reason, b.stop_reason, "{label}");
            for (x, y) in ra.rows.iter().zip(&rb.rows) {
                assert!((x.energy - y.energy).abs() <= 1e-10 * y.energy, "{label} iter {}", x.iter);
                assert_eq!(x.neg_eig, y.neg_eig, "{label} iter {}", x.iter);
            }
        }
    }
}

#[test]
fn cm_and_kp_both_converge_on_nh_and_sarap() {
    // For NH the majorizer differs from KP's eigen-clamp; for SARAP it coincides with it
    // (hess h is diagonal in the singular values, so clamping K drops exactly CM's concave part;
    // see `hessian::cm::tests::cm_equals_kp_for_sarap`).
    let mesh = generate("cap_2k").unwrap();
    for energy in [EnergyKind::Nh(Nh { mu: 0.2, kappa: 0.8 }), EnergyKind::Sarap(Sarap)] {
        let (a, ra) = run(&mesh, energy, "cm");
        let (b, rb) = run(&mesh, energy, "kp-newton");
        let label = energy.name();
        assert!(a.stop_reason.is_converged() && b.stop_reason.is_converged(), "{label}: {a:?} {b:?}");
        check_descent(label, &ra);
        check_descent(label, &rb);
        assert!((a.final_energy - b.final_energy).abs() <= 1e-4 * b.final_energy.max(1.0), "{label}");
        eprintln!("{label}: cm {} kp {} iterations", a.iterations, b.iterations);
    }
}

#[test]
fn unprojected_newton_ends_with_a_recorded_reason() {
    // Plain Newton may stop on an indefinite system; whatever happens is an Outcome, not a panic.
    for mesh in meshes(&["bimba_5k"]) {
        let (out, rec) = run(&mesh, EnergyKind::Sd(Sd), "newton");
        assert_eq!(rec.rows.len(), out.iterations + 1);
        check_descent("newton", &rec);
        eprintln!("{} newton: {} iterations, {}", mesh.source, out.iterations, out.stop_reason.as_str());
    }
}

#[test]
fn undefined_majorizer_is_an_error_not_a_fallback() {
    let mesh = generate("bumpy_1k").unwrap();
    let e = EnergyKind::Bconf(Bconf { k: 1.5 });
    let err = solve_param(&mesh, e, "cm", &ParamSettings::for_energy(&e), &mut Recorder::default()).unwrap_err();
    assert!(err.to_string().contains("k <= 1"), "{err}");
}

/// Every Newton-type strategy on one mesh shares one symbolic analysis through a cache
/// (reused across solvers on the same pattern), with the same iterates
/// as private analyses; a smoothness term changes the pattern and gets its own entry.
#[test]
fn solvers_on_one_mesh_share_the_analysis_and_take_the_same_steps() {
    let mesh = generate("bumpy_1k").unwrap();
    let cache = std::sync::Arc::new(solvers::linear::AnalysisCache::new());
    let strip = |rec: &Recorder| -> Vec<(usize, f64, f64, usize)> {
        rec.rows.iter().map(|r| (r.iter, r.energy, r.grad_norm, r.neg_eig)).collect()
    };
    let mut computed = 0;
    let bconf = EnergyKind::default_for("bconf").unwrap();
    let sd = EnergyKind::Sd(Sd);
    let runs = [(sd, "kp-newton"), (sd, "fp-newton-4x4"), (sd, "cm"), (sd, "slim"), (sd, "akvf"), (bconf, "kp-newton")];
    for (energy, solver) in runs {
        let (private, private_rec) = run(&mesh, energy, solver);
        let mut s = ParamSettings::for_energy(&energy);
        s.solver.analyses = Some(cache.clone());
        let mut rec = Recorder::default();
        let shared = solve_param(&mesh, energy, solver, &s, &mut rec).unwrap();
        assert_eq!(strip(&rec), strip(&private_rec), "{solver} {energy:?}");
        assert_eq!(shared.x, private.x, "{solver} {energy:?}");
        assert!(!private.analysis.unwrap().reused);
        computed += usize::from(!shared.analysis.unwrap().reused);
    }
    assert_eq!((computed, cache.len()), (1, 1));
    let mut s = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
    s.solver.analyses = Some(cache.clone());
    s.smoothness = Some((1e-3, solvers::smoothness::Projection::Analytic));
    let out = solve_param(&mesh, EnergyKind::Sd(Sd), "kp-newton", &s, &mut Recorder::default()).unwrap();
    assert!(!out.analysis.unwrap().reused);
    assert_eq!(cache.len(), 2);
}
