//! One Newton iteration's stages on generated meshes of 5k and 50k vertices (SD at the
//! Tutte map): evaluation (energy, gradient, element states), the line search's energy-only
//! evaluation, KP projection of every element, sparse assembly, numeric factorization +
//! solve, the triangular solves alone (ours and faer's), and the maximal injective step;
//! plus the authalic energy gradient and one AEM preconditioner application.
//! Run with `cargo bench -p mapbench-solvers --bench pipeline`; `cargo test --benches`
//! runs each benchmark once as a smoke test.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Matrix6;
use rayon::prelude::*;
use solvers::assembly::Pattern;
use solvers::energy::{EnergyKind, Sd};
use solvers::generate::generate;
use solvers::hessian::{kp::Kp, SystemBlock};
use solvers::init::{tutte, TutteBoundary};
use solvers::line_search::max_injective_step;
use solvers::linear::ordering::Ordering;
use solvers::linear::{LinearSettings, SpdSolver};
use solvers::problem::{EnergyScratch, Evaluation, MapProblem};
use solvers::tasks::authalic::AuthalicProblem;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    for (label, name) in [("5k", "bumpy_5k"), ("50k", "bumpy_50k")] {
        let mesh = generate(name).expect("generated mesh").normalized();
        let problem = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).expect("no degenerate faces");
        let x = tutte(&mesh, TutteBoundary::Uniform).expect("Tutte embedding");
        let mut ev = Evaluation::default();
        problem.evaluate(&x, &mut ev).expect("Tutte map is in the domain");
        let project = |blocks: &mut Vec<Matrix6<f64>>, ev: &Evaluation| {
            blocks.par_iter_mut().zip(ev.states.par_iter()).zip(problem.ops.par_iter()).for_each(|((b, s), op)| {
                *b = Kp.block(op, s) * problem.weight();
            });
        };
        let mut blocks = vec![Matrix6::zeros(); problem.n_faces()];
        project(&mut blocks, &ev);
        let pattern = Pattern::new(&problem.faces, problem.n_vertices);
        let mut values = Vec::new();
        pattern.assemble(&blocks, &mut values);
        let mut solver = SpdSolver::new(&pattern, Ordering::Metis).expect("symbolic analysis");
        let rhs: Vec<f64> = ev.grad.iter().map(|g| -g).collect();
        let settings = LinearSettings::default();
        let d = solver.solve(&values, &rhs, &settings).expect("KP system is SPD");

        let mut group = c.benchmark_group(format!("pipeline/{label}"));
        group.sample_size(10);
        group.bench_function("evaluate", |b| {
            let mut out = Evaluation::default();
            b.iter(|| problem.evaluate(black_box(&x), &mut out).map(|_| out.energy))
        });
        // The line search's energy-only evaluation (no derivatives, reused buffers).
        group.bench_function("energy_only", |b| {
            let mut scratch = EnergyScratch::default();
            b.iter(|| problem.energy_with(black_box(&x), &mut scratch))
        });
        group.bench_function("project_kp", |b| {
            let mut bl = blocks.clone();
            b.iter(|| {
                project(&mut bl, black_box(&ev));
                bl[0][(0, 0)]
            })
        });
        group.bench_function("assemble", |b| {
            let mut v = Vec::new();
            b.iter(|| {
                pattern.assemble(black_box(&blocks), &mut v);
                v[0]
            })
        });
        group.bench_function("factorize_solve", |b| {
            b.iter(|| solver.solve(black_box(&values), black_box(&rhs), &settings).map(|x| x[0]))
        });
        // The triangular solves alone (the preconditioners' and AEM's per-iteration cost):
        // ours (`triangular`, what the runs use) against faer's, with the same factor, for
        // one right-hand side and for two solved together.
        let mut with_faer = SpdSolver::new(&pattern, Ordering::Metis).expect("symbolic analysis");
        with_faer.set_faer_kernel(true);
        solver.factorize(&values, &settings).expect("KP system is SPD");
        with_faer.factorize(&values, &settings).expect("KP system is SPD");
        let two: Vec<f64> = rhs.iter().chain(&rhs).copied().collect();
        for (label, s) in [("solve", &mut solver), ("solve_faer", &mut with_faer)] {
            group.bench_function(label, |b| b.iter(|| s.solve_factored(black_box(&rhs)).map(|x| x[0])));
            group.bench_function(format!("{label}_2_columns"), |b| {
                let mut x = two.clone();
                b.iter(|| {
                    x.copy_from_slice(&two);
                    s.solve_columns_in_place(black_box(&mut x)).map(|_| x[0])
                })
            });
        }
        // The same matrix with faer's AMD ordering, and the one-off analyses (ordering +
        // symbolic factorization) of both, so `[linear] ordering`'s default stays justified.
        let mut amd = SpdSolver::new(&pattern, Ordering::Amd).expect("symbolic analysis");
        group.bench_function("factorize_solve_amd", |b| {
            b.iter(|| amd.solve(black_box(&values), black_box(&rhs), &settings).map(|x| x[0]))
        });
        for ordering in [Ordering::Metis, Ordering::Amd] {
            group.bench_function(format!("analyse_{}", ordering.as_str()), |b| {
                b.iter(|| SpdSolver::new(black_box(&pattern), ordering).map(|s| s.factor_len()))
            });
        }
        group.bench_function("max_injective_step", |b| {
            b.iter(|| max_injective_step(&problem, black_box(&x), black_box(&d)))
        });

        let auth = AuthalicProblem::new(&generate(name).expect("generated mesh")).expect("disk mesh");
        let z = auth.initial_map(5).expect("initial map");
        group.bench_function("authalic_gradient", |b| b.iter(|| auth.terms_and_gradient(black_box(&z)).0.energy));
        // AEM's preconditioner solve: L_II of the initial map, both interior coordinates as
        // two columns, with our triangular solves and with faer's.
        let mut lap = Vec::new();
        auth.laplacian(Some(&auth.positions_of(&z)), &mut lap);
        let l_ii = auth.block_i.gather(&lap);
        let exact = LinearSettings { tikhonov: 0.0, jacobi: false, ..Default::default() };
        let cols: Vec<f64> = (0..2 * auth.block_i.n).map(|i| (i as f64 * 0.37).sin()).collect();
        for (label, faer) in [("aem_preconditioner_solve", false), ("aem_preconditioner_solve_faer", true)] {
            let mut s = auth.block_solver(&auth.block_i).expect("analysis of L_II");
            s.set_faer_kernel(faer);
            s.factorize(&l_ii, &exact).expect("L_II is SPD");
            group.bench_function(label, |b| {
                let mut x = cols.clone();
                b.iter(|| {
                    x.copy_from_slice(&cols);
                    s.solve_columns_in_place(black_box(&mut x)).map(|_| x[0])
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
