use super::problem::*;
use super::*;
use crate::generate::generate;
use crate::problem::dot;
use crate::solver::Recorder;
use crate::solver::StopReason;
use crate::solver::StopSettings;
use crate::tasks::Task;
use nalgebra::{Matrix6, SymmetricEigen};
use std::f64::consts::PI;

/// A deterministic pseudo-random sequence in [-1, 1].
fn noise(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

fn problem(name: &str) -> AuthalicProblem {
    AuthalicProblem::new(&generate(name).unwrap()).unwrap()
}

/// The initial map of `bumpy_1k` with interior and angles perturbed.
fn perturbed(p: &AuthalicProblem, amount: f64, seed: u64) -> Vec<f64> {
    let mut z = p.initial_map(5).unwrap();
    let mut r = noise(seed);
    let ni = p.n_interior();
    for v in &mut z[..2 * ni] {
        *v += amount * r();
    }
    for v in &mut z[2 * ni..] {
        *v += 0.2 * amount * r();
    }
    z
}

#[test]
fn gradient_matches_finite_differences_in_interior_and_angles() {
    let p = problem("bumpy_1k");
    let z = perturbed(&p, 0.01, 7);
    let (_, g) = p.terms_and_gradient(&z);
    let ni = p.n_interior();
    let h = 1e-6;
    let mut worst = [0.0f64; 2];
    for i in (0..z.len()).step_by(7) {
        let (mut zp, mut zm) = (z.clone(), z.clone());
        zp[i] += h;
        zm[i] -= h;
        let fd = (p.terms(&zp).energy - p.terms(&zm).energy) / (2.0 * h);
        let err = (fd - g[i]).abs() / (1e-3 + g[i].abs());
        let part = usize::from(i >= 2 * ni);
        worst[part] = worst[part].max(err);
    }
    assert!(worst[0] < 1e-5, "interior: {worst:?}");
    assert!(worst[1] < 1e-5, "angles: {worst:?}");
    // every angle checked too (the boundary has few entries)
    for i in 2 * ni..z.len() {
        let (mut zp, mut zm) = (z.clone(), z.clone());
        zp[i] += h;
        zm[i] -= h;
        let fd = (p.terms(&zp).energy - p.terms(&zm).energy) / (2.0 * h);
        assert!((fd - g[i]).abs() <= 1e-5 * (1e-3 + g[i].abs()), "theta {}: fd {fd} vs {}", i - 2 * ni, g[i]);
    }
}

#[test]
fn stretch_gradient_is_twice_the_stretch_laplacian_times_f() {
    // Eq. 11: nabla E_S = 2 (I_2 (x) L_S(f)) f
    let p = problem("cap_2k");
    let z = perturbed(&p, 0.02, 3);
    let x = p.positions_of(&z);
    let gs = p.stretch_gradient(&x);
    let mut values = Vec::new();
    p.laplacian(Some(&x), &mut values);
    for d in 0..2 {
        let xd: Vec<f64> = (0..p.n).map(|v| x[2 * v + d]).collect();
        let lx = p.pattern.mul(&values, &xd);
        for v in 0..p.n {
            assert!((2.0 * lx[v] - gs[2 * v + d]).abs() < 1e-10 * (1.0 + gs[2 * v + d].abs()), "vertex {v}");
        }
    }
    // and E_S = 1/2 f^T (I_2 (x) L_S) f (Eq. 2b)
    let half_form: f64 = (0..2)
        .map(|d| {
            let xd: Vec<f64> = (0..p.n).map(|v| x[2 * v + d]).collect();
            0.5 * dot(&xd, &p.pattern.mul(&values, &xd))
        })
        .sum();
    let t = p.terms(&z);
    assert!((half_form - t.stretch).abs() < 1e-10 * t.stretch);
}

#[test]
fn image_area_is_the_boundary_polygon_area() {
    let p = problem("bumpy_1k");
    let z = perturbed(&p, 0.01, 11);
    let x = p.positions_of(&z);
    let b = &p.boundary;
    let shoelace: f64 = 0.5
        * (0..b.len())
            .map(|i| {
                let (u, v) = (b[i], b[(i + 1) % b.len()]);
                x[2 * u] * x[2 * v + 1] - x[2 * v] * x[2 * u + 1]
            })
            .sum::<f64>();
    let t = p.terms(&z);
    assert!((t.area - shoelace).abs() < 1e-12, "{} vs {shoelace}", t.area);
    // and equal to the sum of the signed image areas of the faces
    let faces: f64 = (0..p.faces.len()).map(|f| p.image_area(&x, f)).sum();
    assert!((t.area - faces).abs() < 1e-10);
    // a regular n-gon: n/2 sin(2 pi / n)
    let n = 12;
    let theta: Vec<f64> = (0..n).map(|k| 2.0 * PI * k as f64 / n as f64).collect();
    assert!((p.polygon_area(&theta) - 0.5 * n as f64 * (2.0 * PI / n as f64).sin()).abs() < 1e-14);
}

#[test]
fn authalic_energy_is_nonnegative_and_zero_for_an_area_preserving_map() {
    // flat_disk_1k is planar with its boundary on the unit circle: the identity is authalic.
    let mesh = generate("flat_disk_1k").unwrap();
    let p = AuthalicProblem::new(&mesh).unwrap();
    let x: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0], q[1]]).collect();
    let m = p.metrics(&p.vars_of(&x));
    assert!(m.authalic_energy.abs() < 1e-12, "{}", m.authalic_energy);
    assert!(m.area_ratio_sd < 1e-12 && m.area_ratio_mad < 1e-12 && m.folded == 0);
    // random maps (folds included) of several meshes: E >= 0
    for (name, amount) in [("bumpy_1k", 0.05), ("cap_2k", 0.2), ("strip_thin", 0.5)] {
        let p = problem(name);
        for seed in 0..4 {
            let t = p.terms(&perturbed(&p, amount, seed));
            assert!(t.area > 0.0);
            assert!(t.energy >= -1e-12 * t.stretch, "{name} {seed}: {}", t.energy);
        }
    }
}

#[test]
fn variables_round_trip_and_angles_unwrap_along_the_loop() {
    let p = problem("bumpy_1k");
    let z = p.initial_map(5).unwrap();
    let theta = &z[2 * p.n_interior()..];
    assert!(theta.windows(2).all(|w| w[1] > w[0]), "arc-length angles increase along the loop");
    let z2 = p.vars_of(&p.positions_of(&z));
    for (a, b) in z.iter().zip(&z2) {
        assert!((a - b).abs() < 1e-12);
    }
}

#[test]
fn element_stretch_hessian_has_exactly_two_negative_eigenvalues() {
    // Justifies `neg_eig = 2 * (faces with non-zero image area)` in authalic CSV rows: the
    // Hessian of A(f)^2 is 2 (grad A grad A^T + A Q) with Q the constant Hessian of the area.
    let mut r = noise(5);
    let area = |y: &[f64; 6]| 0.5 * ((y[2] - y[0]) * (y[5] - y[1]) - (y[3] - y[1]) * (y[4] - y[0]));
    for _ in 0..200 {
        let y: [f64; 6] = std::array::from_fn(|_| r());
        let e = |y: &[f64; 6]| area(y).powi(2);
        let h = 1e-3; // e is a quartic: central differences are exact up to round-off
        let hess = Matrix6::from_fn(|i, j| {
            let at = |di: f64, dj: f64| {
                let mut q = y;
                q[i] += di;
                q[j] += dj;
                e(&q)
            };
            (at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h)) / (4.0 * h * h)
        });
        let ev = SymmetricEigen::new(hess).eigenvalues;
        let scale = ev.amax();
        let neg = ev.iter().filter(|&&l| l < -1e-6 * scale).count();
        assert_eq!(neg, 2, "A = {}: {ev:?}", area(&y));
    }
}

fn run_with(
    name: &str,
    solver: &str,
    settings: &AuthalicSettings,
) -> (AuthalicOutcome, Vec<crate::solver::IterationRecord>) {
    let mut rec = Recorder::default();
    let out = solve_authalic(&generate(name).unwrap(), solver, settings, &mut rec).unwrap();
    (out, rec.rows)
}

fn run(name: &str, solver: &str, iters: usize) -> (AuthalicOutcome, Vec<crate::solver::IterationRecord>) {
    let settings = AuthalicSettings { stop: StopSettings { max_iters: iters, ..default_stop() }, ..Default::default() };
    run_with(name, solver, &settings)
}

fn extra(r: &crate::solver::IterationRecord, name: &str) -> f64 {
    r.extra_value(name).unwrap()
}

#[test]
fn aem_cg_beats_sem_on_the_thin_strip() {
    // strip_thin (50:1): SEM oscillates (energy rises in about half of its steps) and folds.
    let (sem, sem_rows) = run("strip_thin", "sem", 60);
    let (aem, aem_rows) = run("strip_thin", "aem-cg", 60);
    let (safe, safe_rows) = run("strip_thin", "aem-cg-safe", 60);
    // same initial map for all three
    assert_eq!(sem_rows[0].energy, aem_rows[0].energy);
    assert_eq!(sem_rows[0].energy, safe_rows[0].energy);
    for (label, o, rows) in [("sem", &sem, &sem_rows), ("aem-cg", &aem, &aem_rows), ("aem-cg-safe", &safe, &safe_rows)]
    {
        assert_eq!(rows.len(), 61, "{label}: the fixed budget of the paper's Table 1");
        assert!(o.outcome.final_energy >= 0.0 && o.outcome.final_energy < rows[0].energy, "{label}");
        assert_eq!(o.metrics.authalic_energy, o.outcome.final_energy);
        for r in rows.iter() {
            assert_eq!(r.extra.iter().map(|e| e.0).collect::<Vec<_>>(), AUTHALIC_COLUMNS);
            assert_eq!(
                extra(r, "ascent") == 1.0,
                r.iter > 0 && r.energy > rows[r.iter - 1].energy,
                "{label} {}",
                r.iter
            );
        }
    }
    let sem_ascents = sem_rows.iter().filter(|r| extra(r, "ascent") == 1.0).count();
    assert!(sem_ascents >= 5, "{sem_ascents}");
    assert!(
        aem.outcome.final_energy < 0.2 * sem.outcome.final_energy,
        "{} vs {}",
        aem.outcome.final_energy,
        sem.outcome.final_energy
    );
    assert!(aem.metrics.area_ratio_sd < sem.metrics.area_ratio_sd);
    assert_eq!(aem.metrics.folded, 0);
    assert_eq!(safe.metrics.folded, 0);
    // SEMc's rule: stop at the first increase, keeping the previous iterate
    let settings = AuthalicSettings { sem_stop_on_increase: true, ..Default::default() };
    let (semc, semc_rows) = run_with("strip_thin", "sem", &settings);
    assert_eq!(semc.outcome.stop_reason, StopReason::EnergyIncreased);
    assert!(semc_rows.windows(2).all(|w| w[1].energy <= w[0].energy));
}

#[test]
fn safeguards_fire_and_keep_the_descent_monotone_where_the_faithful_method_ascends() {
    // A tiny first trial step drowns the curvature of Eq. 18 in round-off: its quadratic has
    // a2 <= 0 or a meaningless minimizer.
    let settings =
        AuthalicSettings { stop: StopSettings { max_iters: 40, ..default_stop() }, alpha0: 1e-9, ..Default::default() };
    let (faithful, f_rows) = run_with("bumpy_1k", "aem-cg", &settings);
    // Whether round-off derails the quadratic step depends on the last bits of the solves, so
    // the safe run also asks for more decrease than any quadratic's minimizer gives (Armijo
    // c1 = 0.9 > 1/2): its backtracking must fire whatever the round-off.
    let (safe, s_rows) = run_with("bumpy_1k", "aem-cg-safe", &AuthalicSettings { armijo_c: 0.9, ..settings });
    let fired = |name: &str| s_rows.iter().map(|r| extra(r, name)).sum::<f64>();
    assert!(fired("backtracks") + fired("quad_fallback") + fired("restarted") > 0.0);
    assert!(s_rows.windows(2).all(|w| w[1].energy <= w[0].energy), "Armijo keeps the energy monotone");
    assert!(safe.outcome.final_energy < s_rows[0].energy);
    assert_eq!(safe.metrics.folded, 0);
    // the faithful method records whatever happens: an ascent row for every rise, no other
    // (whether round-off makes it rise here depends on the solves' last bits)
    for w in f_rows.windows(2) {
        assert_eq!(extra(&w[1], "ascent") == 1.0, w[1].energy > w[0].energy, "iteration {}", w[1].iter);
    }
    assert_eq!(faithful.outcome.stop_reason, StopReason::MaxIterations);
}

#[test]
fn bad_meshes_are_typed_errors_naming_the_source() {
    let mut mesh = generate("bumpy_1k").unwrap();
    mesh.source = "holes.obj".into();
    // cut a hole: drop the faces around the centre vertex
    mesh.faces.retain(|f| !f.contains(&0));
    mesh.positions[0] = [9.0, 9.0, 9.0];
    let err = AuthalicProblem::new(&mesh).err().unwrap().to_string();
    assert!(err.contains("holes.obj"), "{err}");
    let err = solve_authalic(&generate("bumpy_1k").unwrap(), "sem2", &Default::default(), &mut Recorder::default())
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("unknown authalic solver 'sem2'"));
}

#[test]
fn a_passed_deadline_stops_each_authalic_solver_with_timeout() {
    let mesh = generate("bumpy_1k").unwrap();
    for solver in ["sem", "aem-cg", "aem-cg-safe"] {
        for k in [0, 2] {
            let mut obs = crate::solver::TimeoutAt(k);
            let out = solve_authalic(&mesh, solver, &AuthalicSettings::default(), &mut obs).unwrap();
            assert_eq!(out.outcome.stop_reason, StopReason::Timeout, "{solver} at {k}");
            assert_eq!(out.outcome.iterations, k, "{solver}");
        }
    }
}

#[test]
fn each_authalic_name_is_dispatched_to_exactly_its_method() {
    let mesh = generate("bumpy_1k").unwrap();
    // Armijo's c1 above 1/2 rejects the quadratic step, so `aem-cg-safe` backtracks where
    // `aem-cg` does not: the two paths differ from the first step on.
    let settings =
        AuthalicSettings { stop: StopSettings { max_iters: 4, ..default_stop() }, armijo_c: 0.9, ..Default::default() };
    let energies = |rows: &[crate::solver::IterationRecord]| rows.iter().map(|r| r.energy).collect::<Vec<_>>();
    // Pinned here, not read from the catalogue: a catalogue entry with the wrong method fails.
    let direct = |name: &str| {
        let problem = AuthalicProblem::new(&mesh).unwrap();
        let z0 = problem.initial_map(settings.init_steps).unwrap();
        let mut rec = Recorder::default();
        match name {
            "sem" => sem::sem(&problem, z0, &settings, &mut rec),
            "aem-cg" => aem::aem_cg(&problem, z0, &settings, false, &mut rec),
            "aem-cg-safe" => aem::aem_cg(&problem, z0, &settings, true, &mut rec),
            _ => unreachable!("not an authalic solver"),
        };
        energies(&rec.rows)
    };
    let mut seen = Vec::new();
    let expected = ["sem", "aem-cg", "aem-cg-safe"];
    assert_eq!(crate::tasks::catalogue::names_for(Task::Authalic), expected);
    for name in expected {
        let mut rec = Recorder::default();
        solve_authalic(&mesh, name, &settings, &mut rec).unwrap();
        let rows = energies(&rec.rows);
        assert_eq!(rows, direct(name), "{name}");
        seen.push(rows);
    }
    // the three paths differ, so a wrong dispatch would show
    assert_eq!(seen.len(), 3);
    assert!(seen[0] != seen[1] && seen[1] != seen[2] && seen[0] != seen[2], "{seen:?}");
}

#[test]
fn a_newton_solver_is_refused_by_name() {
    let err =
        solve_authalic(&generate("bumpy_1k").unwrap(), "kp-newton", &Default::default(), &mut Recorder::default())
            .err()
            .unwrap()
            .to_string();
    assert!(err.starts_with("'kp-newton' is a param/deform solver: task authalic runs sem, aem-cg, aem-cg-safe"));
}

/// The initial map and the solver after it factorize `L_II` with one analysis: the second
/// block solver of a problem reuses the first one's, and each block has its own.
#[test]
fn the_blocks_are_analysed_once_per_problem() {
    let p = problem("bumpy_1k");
    p.initial_map(2).unwrap();
    let again = p.block_solver(&p.block_i).unwrap();
    assert!(again.analysis_reused(), "L_II was analysed again");
    let boundary = p.block_solver(&p.block_b).unwrap();
    assert!(!boundary.analysis_reused(), "L_BB took L_II's analysis");
    assert!(std::sync::Arc::ptr_eq(again.analysis(), p.block_solver(&p.block_i).unwrap().analysis()));
    assert!(p.block_solver(&p.block_b).unwrap().analysis_reused());
}

/// Buffers kept between evaluations (AEM-CG's loop) leave nothing behind: evaluating at `b`
/// after `a` with the same buffers gives what fresh buffers give at `b`, bit for bit, and the
/// positions are the interior values and the boundary's `(cos theta, sin theta)`.
#[test]
fn evaluations_with_reused_buffers_equal_fresh_ones() {
    let p = problem("bumpy_1k");
    let (a, b) = (perturbed(&p, 0.01, 3), perturbed(&p, 0.02, 4));
    let mut buf = EvalBuffers::default();
    let mut g = Vec::new();
    p.terms_and_gradient_into(&a, &mut buf, &mut g);
    let t = p.terms_and_gradient_into(&b, &mut buf, &mut g);
    let (fresh_t, fresh_g) = p.terms_and_gradient(&b);
    assert_eq!(t, fresh_t);
    assert!(g.iter().zip(&fresh_g).all(|(x, y)| x.to_bits() == y.to_bits()) && g.len() == fresh_g.len());
    p.terms_with(&a, &mut buf);
    assert_eq!(p.terms_with(&b, &mut buf), p.terms(&b));
    let x = p.positions_of(&b);
    let ni = p.n_interior();
    for (i, &v) in p.interior.iter().enumerate() {
        assert_eq!((x[2 * v], x[2 * v + 1]), (b[i], b[ni + i]));
    }
    for (k, &v) in p.boundary.iter().enumerate() {
        assert_eq!((x[2 * v], x[2 * v + 1]), (b[2 * ni + k].cos(), b[2 * ni + k].sin()));
    }
}
