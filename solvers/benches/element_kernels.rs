//! Per-element kernels: energy modifiers, KP / FP4 / FP6 / CM system blocks, per energy.
//! Run with `cargo bench -p mapbench-solvers`; `cargo test --benches` runs each once.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use solvers::energy::{EnergyKind, ENERGY_NAMES};
use solvers::hessian::{cm::Cm, fp::Fp4, fp::Fp6, kp::Kp, ElementState, SystemBlock};
use solvers::local::LocalOp;
use std::hint::black_box;

/// 256 fixed, moderately distorted orientation-preserving elements.
fn elements(e: &EnergyKind) -> Vec<(LocalOp, ElementState)> {
    let mut seed = 0x9E3779B97F4A7C15u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
    };
    let mut out = Vec::new();
    while out.len() < 256 {
        let z = [[next(), next()], [next(), next()], [next(), next()]];
        let Some(op) = LocalOp::from_planar(z) else { continue };
        let y = [[next(), next()], [next(), next()], [next(), next()]];
        let w = op.wirtinger(y);
        if let Some(m) = e.modifiers(w.x(), w.y()) {
            if w.x() > 1.2 * w.y() {
                out.push((op, ElementState::new(w, m)));
            }
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    for name in ENERGY_NAMES {
        let e = EnergyKind::default_for(name).expect("built-in energy");
        let els = elements(&e);
        let mut group = c.benchmark_group(format!("element/{name}"));
        group.bench_function("modifiers", |b| {
            b.iter(|| {
                els.iter()
                    .map(|(_, s)| e.modifiers(black_box(s.x()), black_box(s.y())).map_or(0.0, |m| m.b1))
                    .sum::<f64>()
            })
        });
        let strategies: Vec<(&str, Box<dyn SystemBlock>)> = {
            let mut v: Vec<(&str, Box<dyn SystemBlock>)> =
                vec![("kp", Box::new(Kp)), ("fp4", Box::new(Fp4)), ("fp6", Box::new(Fp6))];
            if let Ok(cm) = Cm::for_energy(&e) {
                v.push(("cm", Box::new(cm)));
            }
            v
        };
        for (label, s) in &strategies {
            group.bench_function(*label, |b| {
                b.iter_batched(
                    || (),
                    |_| els.iter().map(|(op, st)| s.block(black_box(op), black_box(st))[(0, 0)]).sum::<f64>(),
                    BatchSize::SmallInput,
                )
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
