//! SLIM and AKVF on the shared pipeline: their directions come from
//! their proxy systems, then the same injective Armijo line search and stopping rules.

use solvers::energy::{EnergyKind, Sd};
use solvers::generate::generate;
use solvers::mesh::{load_obj, Mesh};
use solvers::solver::{Outcome, Recorder};
use solvers::tasks::param::{solve_param, ParamSettings};

fn run(mesh: &Mesh, solver: &str) -> (Outcome, Recorder) {
    let e = EnergyKind::Sd(Sd);
    let settings = ParamSettings::for_energy(&e);
    let mut rec = Recorder::default();
    let out = solve_param(mesh, e, solver, &settings, &mut rec).unwrap_or_else(|err| panic!("{solver}: {err}"));
    (out, rec)
}

/// Runs KP, SLIM and AKVF; checks descent, no flips and final energies within 0.5% of KP's.
/// Returns the iteration counts (kp, slim, akvf).
fn compare(mesh: &Mesh) -> [usize; 3] {
    let (kp, _) = run(mesh, "kp-newton");
    assert!(kp.stop_reason.is_converged(), "{}: kp {:?}", mesh.source, kp.stop_reason);
    let mut its = [kp.iterations, 0, 0];
    for (i, solver) in ["slim", "akvf"].into_iter().enumerate() {
        let (out, rec) = run(mesh, solver);
        let label = format!("{} {solver}", mesh.source);
        for w in rec.rows.windows(2) {
            assert!(w[1].energy <= w[0].energy, "{label}: energy increased at {}", w[1].iter);
            assert_eq!(w[1].flips, 0, "{label}: flip at {}", w[1].iter);
        }
        let rel = (out.final_energy - kp.final_energy).abs() / kp.final_energy;
        assert!(rel <= 5e-3, "{label}: {} vs kp {}", out.final_energy, kp.final_energy);
        its[i + 1] = out.iterations;
        eprintln!(
            "{label}: {} iterations ({}), E = {:.6} (kp: {} iterations, E = {:.6}), {:.2} s",
            out.iterations,
            out.stop_reason.as_str(),
            out.final_energy,
            kp.iterations,
            kp.final_energy,
            rec.rows.last().map_or(0.0, |r| r.t_cum_s)
        );
    }
    its
}

#[test]
fn slim_and_akvf_reach_kp_energy_on_generated_meshes() {
    for name in ["bumpy_1k", "cap_2k"] {
        let [kp, slim, _] = compare(&generate(name).unwrap());
        assert!(kp < slim, "{name}: kp {kp} slim {slim}");
    }
}

#[test]
fn slim_and_akvf_on_shared_corpus() {
    let Ok(dir) = std::env::var("MAPBENCH_MESHES") else {
        eprintln!("MAPBENCH_MESHES not set: shared-corpus test skipped");
        return;
    };
    let mut total = [0; 3];
    for name in ["bunnyhead", "camelhead", "horse"] {
        let mesh = load_obj(&std::path::Path::new(&dir).join(format!("{name}.obj"))).unwrap();
        let [kp, slim, akvf] = compare(&mesh);
        // KP is far ahead of SLIM everywhere. AKVF is competitive on horse (29 iterations vs
        // KP's 30, to a lower energy): every projected Newton variant has a linear tail there
        // (FP4 38, CM 44), and the complex-view paper says AKVF is competitive on some inputs
        // (Section 6.1; its Table 4 compares averages). So per mesh KP is required to be
        // ahead of AKVF on the other two, and to need fewer than half of AKVF's iterations in
        // total (measured: 128 against 386).
        assert!(kp < slim, "{name}: kp {kp} slim {slim}");
        if name != "horse" {
            assert!(kp < akvf, "{name}: kp {kp} akvf {akvf}");
        }
        for (t, n) in total.iter_mut().zip([kp, slim, akvf]) {
            *t += n;
        }
    }
    assert!(2 * total[0] < total[2], "KP {} vs AKVF {} iterations in total", total[0], total[2]);
}
