//! The `param` task: free-boundary isometric parameterization of a disk-topology surface
//! from a Tutte initialization (complex-view paper, Section 6.1).

use crate::energy::{EnergyKind, Sd};
use crate::init::{global_scale, tutte, TutteBoundary};
use crate::mesh::Mesh;
use crate::problem::MapProblem;
use crate::smoothness::Projection;
use crate::solver::{Observer, Outcome, RawOptions, Settings, StartMap, StopAt, StopSettings};
use crate::tasks::catalogue::{lookup, Start};
use crate::tasks::map_task::MapError;
use crate::tasks::map_task::{checked_solver, map_problem};
use crate::tasks::Task;

/// Which map every solver of a `param` run starts from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ParamStart {
    /// The Tutte map, globally scaled for the energies with the scaling rule (Section 4.2):
    /// the papers' start.
    #[default]
    Tutte,
    /// The SD minimum of the same problem (mesh, Tutte boundary, smoothness term), reached
    /// by Newton from the Tutte start. An energy that grows like `exp(s SD)` overflows at the
    /// Tutte map of most real meshes (an element there has an SD in the thousands); at the SD
    /// minimum every element is near isometric, so every solver can start (exp-SD's start in
    /// the harness: the book's numerics page, "Starts").
    SdMinimum,
}

/// The stop rule of [`sd_minimum`]: a tight gradient tolerance and a long budget, so the
/// chained start does not depend on how a batch stops its SD runs.
pub const SD_MINIMUM_STOP: StopSettings = StopSettings::rules_only(1e-8, 0.0, 5000);

/// Settings of a `param` run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ParamSettings {
    /// Stopping rule, line search, linear solves and solver options.
    pub solver: Settings,
    /// How the Tutte start places the boundary on the circle.
    pub tutte_boundary: TutteBoundary,
    /// Jump threshold of the global-scaling heuristic (Section 4.2; the paper uses 0.1).
    pub scaling_jump: f64,
    /// The smoothness term (Section 4.3): weight and projection of its 8x8 blocks.
    pub smoothness: Option<(f64, Projection)>,
    /// Which map every solver starts from.
    pub start: ParamStart,
}

/// The `param` defaults (docs/src/design/numerics.md): `|grad| <= 1e-3`, 1000 iterations, and the energy's own decrease
/// rule if it has one (SARAP's, `energy_decrease_tol`).
pub fn default_stop(energy: &EnergyKind) -> StopSettings {
    StopSettings { energy_decrease_tol: energy.energy_decrease_tol(), ..StopSettings::default() }
}

/// Jump threshold of the global-scaling heuristic in the paper (Section 4.2).
pub const DEFAULT_SCALING_JUMP: f64 = 0.1;

impl ParamSettings {
    /// The papers' settings for `energy`: [`default_stop`], the default line search and linear
    /// solves, the uniform Tutte boundary, the paper's scaling jump, no smoothness term, the
    /// Tutte start.
    pub fn for_energy(energy: &EnergyKind) -> ParamSettings {
        ParamSettings {
            solver: Settings { stop: default_stop(energy), ..Settings::default() },
            tutte_boundary: TutteBoundary::Uniform,
            scaling_jump: DEFAULT_SCALING_JUMP,
            smoothness: None,
            start: ParamStart::Tutte,
        }
    }
}

/// Parameterize `mesh` (validated here: it must be a topological disk) with `energy` and the
/// named solver. The mesh is centred and scaled to area 1 first.
pub fn solve_param(
    mesh: &Mesh,
    energy: EnergyKind,
    solver: &str,
    settings: &ParamSettings,
    observer: &mut dyn Observer,
) -> Result<Outcome, MapError> {
    solve_param_with(mesh, energy, solver, settings, None, observer)
}

/// [`solve_param`] with the SD minimum of the problem when the caller has it (normalized
/// frame; the harness keeps it as a reference): the start of [`ParamStart::SdMinimum`], which
/// is computed ([`sd_minimum`]) when `None`. Ignored with the Tutte start.
pub fn solve_param_with(
    mesh: &Mesh,
    energy: EnergyKind,
    solver: &str,
    settings: &ParamSettings,
    sd_min: Option<&[f64]>,
    observer: &mut dyn Observer,
) -> Result<Outcome, MapError> {
    let built = checked_solver(mesh, Task::Param, &energy, solver, &settings.solver.options)?;
    let mesh = mesh.normalized();
    let problem = map_problem(&mesh, energy, built.smoothness_projection(), settings.smoothness)?;
    let own = lookup(solver, Task::Param)?.start;
    let (x, start) = run_start(&mesh, &problem, own, settings, sd_min)?;
    let mut outcome = built
        .solve(&problem, x, &settings.solver, observer)
        .map_err(|err| MapError::Solve { source_name: mesh.source.clone(), err })?;
    outcome.start = Some(start);
    Ok(outcome)
}

/// The problem of a `param` run without a smoothness term, and its common start, in the
/// normalized frame, after the checks of the mesh a run makes: what a solver outside the
/// catalogue is given and judged on (`deform::deform_start` for `deform`).
pub fn param_start(
    mesh: &Mesh,
    energy: EnergyKind,
    settings: &ParamSettings,
    sd_min: Option<&[f64]>,
) -> Result<(MapProblem, Vec<f64>, StartMap), MapError> {
    common_start(mesh, energy, settings, None, sd_min)
}

/// The problem a `param` run with `settings` is judged on (its energy with the smoothness
/// term, whose value does not depend on how a solver projects its blocks) and the common
/// start, in the normalized frame: what the harness's reference minima and verdicts measure.
pub fn judged_problem(
    mesh: &Mesh,
    energy: EnergyKind,
    settings: &ParamSettings,
    sd_min: Option<&[f64]>,
) -> Result<(MapProblem, Vec<f64>, StartMap), MapError> {
    common_start(mesh, energy, settings, settings.smoothness, sd_min)
}

/// The checked mesh's problem with `smoothness` and its common start, normalized frame.
fn common_start(
    mesh: &Mesh,
    energy: EnergyKind,
    settings: &ParamSettings,
    smoothness: Option<(f64, crate::smoothness::Projection)>,
    sd_min: Option<&[f64]>,
) -> Result<(MapProblem, Vec<f64>, StartMap), MapError> {
    energy.check().map_err(MapError::Energy)?;
    crate::tasks::validate_for(mesh, Task::Param).into_result()?;
    let rest = mesh.normalized();
    let problem = map_problem(&rest, energy, None, smoothness)?;
    let (x, start) = run_start(&rest, &problem, Start::Common, settings, sd_min)?;
    Ok((problem, x, start))
}

/// The start of a run whose solver declares `own` ([`start_map`]), or the SD minimum with
/// [`ParamStart::SdMinimum`] (`sd_min` when given, else computed), the same for every solver.
fn run_start(
    rest: &Mesh,
    problem: &MapProblem,
    own: Start,
    settings: &ParamSettings,
    sd_min: Option<&[f64]>,
) -> Result<(Vec<f64>, StartMap), MapError> {
    match (settings.start, sd_min) {
        (ParamStart::Tutte, _) => start_map(rest, problem, own, settings),
        (ParamStart::SdMinimum, Some(x)) if x.len() == 2 * rest.n_vertices() => Ok((x.to_vec(), StartMap::SdMinimum)),
        (ParamStart::SdMinimum, Some(x)) => Err(MapError::BadInit {
            source_name: rest.source.clone(),
            detail: format!("the SD minimum has {} coordinates for {} vertices", x.len(), rest.n_vertices()),
        }),
        (ParamStart::SdMinimum, None) => Ok((sd_minimum(rest, settings)?, StartMap::SdMinimum)),
    }
}

/// The SD minimum of the normalized mesh `rest` with the Tutte boundary, scaling jump and
/// smoothness weight of `settings`: `kp-newton` from the common start with [`SD_MINIMUM_STOP`]
/// and the batch's line search and linear settings. A run that does not reach the tolerance
/// still gives its last map: a start, not a reference.
pub fn sd_minimum(rest: &Mesh, settings: &ParamSettings) -> Result<Vec<f64>, MapError> {
    let sd = EnergyKind::Sd(Sd);
    let built = checked_solver(rest, Task::Param, &sd, "kp-newton", &RawOptions::new())?;
    let problem = map_problem(rest, sd, built.smoothness_projection(), settings.smoothness)?;
    let (x, _) = start_map(rest, &problem, Start::Common, settings)?;
    let solver = Settings { stop: SD_MINIMUM_STOP, options: RawOptions::new(), ..settings.solver.clone() };
    let out = built
        .solve(&problem, x, &solver, &mut StopAt(usize::MAX))
        .map_err(|err| MapError::Solve { source_name: rest.source.clone(), err })?;
    Ok(out.x)
}

/// [`solve_param`] from the map `x` (normalized frame, one `u v` pair per vertex) instead of
/// the solver's start: how the harness polishes a map it keeps as a reference minimum or
/// checks that a run stopped at another minimum.
pub fn solve_param_from(
    mesh: &Mesh,
    energy: EnergyKind,
    solver: &str,
    settings: &ParamSettings,
    x: Vec<f64>,
    observer: &mut dyn Observer,
) -> Result<Outcome, MapError> {
    let built = checked_solver(mesh, Task::Param, &energy, solver, &settings.solver.options)?;
    let mesh = mesh.normalized();
    if x.len() != 2 * mesh.n_vertices() {
        return Err(MapError::BadInit {
            source_name: mesh.source.clone(),
            detail: format!("{} coordinates for {} vertices", x.len(), mesh.n_vertices()),
        });
    }
    let problem = map_problem(&mesh, energy, built.smoothness_projection(), settings.smoothness)?;
    built
        .solve(&problem, x, &settings.solver, observer)
        .map_err(|err| MapError::Solve { source_name: mesh.source.clone(), err })
}

/// The start of a run with a solver whose catalogue entry says `start`: the common start is
/// the Tutte map scaled by Section 4.2's rule for the energies that define it (the Tutte map
/// for the others), the same for every solver; `kp-newton-noscale` keeps the Tutte map.
pub fn start_map(
    mesh: &Mesh,
    problem: &MapProblem,
    start: Start,
    settings: &ParamSettings,
) -> Result<(Vec<f64>, StartMap), MapError> {
    let init_err = |err| MapError::Init { source_name: mesh.source.clone(), err };
    let mut x = tutte(mesh, settings.tutte_boundary).map_err(init_err)?;
    let scale = match start {
        Start::Common => global_scale(problem, &x, settings.scaling_jump),
        Start::TutteUnscaled => None,
    };
    Ok(match scale {
        Some(s) => {
            x.iter_mut().for_each(|v| *v *= s);
            (x, StartMap::TutteScaled)
        }
        None => (x, StartMap::Tutte),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Sarap, Sd};
    use crate::generate::generate;
    use crate::solver::Recorder;

    fn run(mesh: &Mesh) -> Result<Outcome, MapError> {
        let energy = EnergyKind::Sd(Sd);
        solve_param(mesh, energy, "kp-newton", &ParamSettings::for_energy(&energy), &mut Recorder::default())
    }

    /// What an external solver is given is what ours start from: the same map and energy.
    #[test]
    fn param_start_is_the_problem_and_start_of_a_run() {
        let mesh = generate("bumpy_1k").unwrap();
        let energy = EnergyKind::Sd(Sd);
        let mut settings = ParamSettings::for_energy(&energy);
        settings.solver.stop.max_iters = 0;
        let (problem, x, start) = param_start(&mesh, energy, &settings, None).unwrap();
        let mut rec = Recorder::default();
        let out = solve_param(&mesh, energy, "kp-newton", &settings, &mut rec).unwrap();
        assert_eq!((out.x, out.start), (x.clone(), Some(start)));
        assert_eq!(problem.energy(&x).to_bits(), rec.rows[0].energy.to_bits());
    }

    /// Every param solver starts from the same map, the Tutte map scaled for the energies
    /// with the scaling rule, except the one that declares its own (`kp-newton-noscale`).
    #[test]
    fn every_solver_starts_from_the_common_map_unless_it_declares_its_own() {
        use crate::tasks::catalogue::names_for;
        let mesh = generate("bumpy_1k").unwrap();
        for (energy, scaled) in
            [(EnergyKind::Sd(Sd), StartMap::TutteScaled), (EnergyKind::Sarap(Sarap), StartMap::Tutte)]
        {
            let mut settings = ParamSettings::for_energy(&energy);
            settings.solver.stop.max_iters = 1;
            let mut starts = Vec::new();
            for name in names_for(Task::Param) {
                let entry = lookup(name, Task::Param).unwrap();
                if entry.skip_reason(Task::Param, &energy, &crate::solver::RawOptions::new()).is_some() {
                    continue;
                }
                let mut rec = Recorder::default();
                let out = solve_param(&mesh, energy, name, &settings, &mut rec).unwrap();
                starts.push((name, entry.start, out.start, rec.rows[0].energy.to_bits()));
            }
            assert!(starts.len() >= 15, "{starts:?}");
            let common = starts.iter().find(|s| s.0 == "kp-newton").unwrap().3;
            let unscaled = starts.iter().find(|s| s.0 == "kp-newton-noscale").unwrap().3;
            assert_eq!(common != unscaled, scaled == StartMap::TutteScaled, "{}", energy.name());
            for (name, declared, start, e0) in &starts {
                match declared {
                    Start::Common => assert_eq!((*start, *e0), (Some(scaled), common), "{name} {}", energy.name()),
                    Start::TutteUnscaled => assert_eq!((*start, *e0), (Some(StartMap::Tutte), unscaled), "{name}"),
                }
            }
        }
    }

    /// exp-SD (s = 1) overflows at the Tutte map of strip_thin; from the SD minimum every
    /// solver starts at one map, the one a caller brings is taken as it is, and the runs finish.
    #[test]
    fn exp_sd_starts_from_the_sd_minimum_where_the_tutte_map_overflows() {
        use crate::energy::ExpSd;
        let mesh = generate("strip_thin").unwrap();
        let energy = EnergyKind::ExpSd(ExpSd { s: 1.0 });
        let mut settings = ParamSettings::for_energy(&energy);
        let err = solve_param(&mesh, energy, "kp-newton", &settings, &mut Recorder::default()).unwrap_err();
        assert!(err.to_string().contains("non-finite"), "{err}");
        settings.start = ParamStart::SdMinimum;
        let rest = mesh.normalized();
        let x_sd = sd_minimum(&rest, &settings).unwrap();
        for solver in ["kp-newton", "kp-newton-noscale", "slim", "lbfgs"] {
            let mut rec = Recorder::default();
            let out = solve_param(&mesh, energy, solver, &settings, &mut rec).unwrap();
            assert_eq!(out.start, Some(StartMap::SdMinimum), "{solver}");
            let (problem, x0, _) = param_start(&mesh, energy, &settings, None).unwrap();
            assert_eq!(x0, x_sd, "{solver}");
            assert_eq!(rec.rows[0].energy.to_bits(), problem.energy(&x_sd).to_bits(), "{solver}");
            assert!(out.final_energy.is_finite() && out.flips == 0 && out.final_energy <= rec.rows[0].energy);
        }
        // a given map is the start as it is (the harness brings the stored SD minimum)
        let shifted: Vec<f64> = x_sd.iter().map(|v| v + 0.5).collect();
        let mut rec = Recorder::default();
        let out = solve_param_with(&mesh, energy, "kp-newton", &settings, Some(&shifted), &mut rec).unwrap();
        let (problem, x0, start) = param_start(&mesh, energy, &settings, Some(&shifted)).unwrap();
        assert_eq!((x0, start, out.start), (shifted.clone(), StartMap::SdMinimum, Some(StartMap::SdMinimum)));
        assert_eq!(rec.rows[0].energy.to_bits(), problem.energy(&shifted).to_bits());
        let Err(err) = param_start(&mesh, energy, &settings, Some(&shifted[2..])) else { panic!("a short map") };
        assert!(err.to_string().contains("coordinates for"), "{err}");
        // the SD minimum is one: its gradient is below the chained start's tolerance
        let sd = crate::problem::MapProblem::new(&rest, EnergyKind::Sd(Sd)).unwrap();
        let mut ev = crate::problem::Evaluation::default();
        sd.evaluate_without_inertia(&x_sd, &mut ev).unwrap();
        assert!(crate::problem::norm(&ev.grad) <= SD_MINIMUM_STOP.grad_tol, "{}", crate::problem::norm(&ev.grad));
    }

    /// The same surface drawn the other way round, lifted to z = 5, or in units of 1e300 (areas
    /// overflow) or 1e-300 (they underflow) parameterizes like the original.
    #[test]
    fn orientation_and_units_do_not_matter() {
        let disk = generate("flat_disk_1k").unwrap();
        let bumpy = generate("bumpy_1k").unwrap();
        let mut mirrored = disk.clone();
        mirrored.faces.iter_mut().for_each(|f| f.swap(1, 2));
        mirrored.positions.iter_mut().for_each(|p| p[2] = 5.0);
        let scaled = |m: &Mesh, k: f64| {
            Mesh::new(m.source.clone(), m.positions.iter().map(|p| p.map(|c| c * k)).collect(), m.faces.clone())
        };
        let cases = [
            (&disk, mirrored),
            (&bumpy, scaled(&bumpy, 1e300)),
            (&bumpy, scaled(&bumpy, 1e-300)),
            (&disk, scaled(&disk, 1e200)),
        ];
        for (k, (orig, other)) in cases.iter().enumerate() {
            let a = run(orig).unwrap();
            let b = run(other).unwrap_or_else(|e| panic!("case {k}: {e}"));
            assert!(b.stop_reason.is_converged() && b.flips == 0, "case {k}: {:?}", b.stop_reason);
            let rel = (a.final_energy - b.final_energy).abs() / a.final_energy;
            assert!(rel < 1e-6, "case {k}: {} vs {}", a.final_energy, b.final_energy);
        }
    }

    /// Unprojected Newton stops at its first failed factorization (CM paper, Figure 2): on
    /// bumpy_1k with SD the common start has indefinite element Hessians and the system at
    /// the last iterate is not positive definite. With the retry the projected solvers keep, the
    /// same blocks "converge" as shifted Newton, which is what `newton` used to report.
    #[test]
    fn newton_stops_at_its_first_failed_factorization_where_shifted_newton_would_go_on() {
        use crate::hessian::{none::Unprojected, ElementState, SystemBlock};
        use crate::solver::{newton::newton, StopReason};
        let mesh = generate("bumpy_1k").unwrap();
        let settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
        let mut rec = Recorder::default();
        let out = solve_param(&mesh, EnergyKind::Sd(Sd), "newton", &settings, &mut rec).unwrap();
        assert!(matches!(out.stop_reason, StopReason::LinearSolveFailed(_)), "{:?}", out.stop_reason);
        let detail = out.stop_reason.detail().unwrap();
        assert!(
            detail.starts_with(&format!("the system at iterate {}: ", out.iterations))
                && detail.ends_with("(shift 1e-10, no retry)"),
            "{detail}"
        );
        assert_eq!(rec.rows.len(), out.iterations + 1);
        assert!(rec.rows.last().unwrap().indefinite_elems > 0, "{:?}", rec.rows.last());

        /// The unprojected blocks with the driver's retry.
        struct Shifted;
        impl SystemBlock for Shifted {
            fn block(&self, op: &crate::local::LocalOp, s: &ElementState) -> nalgebra::Matrix6<f64> {
                Unprojected.block(op, s)
            }
        }
        let normalized = mesh.normalized();
        let problem = crate::problem::MapProblem::new(&normalized, EnergyKind::Sd(Sd)).unwrap();
        // From the unscaled Tutte map (1064 indefinite element Hessians, not positive
        // definite at iterate 0) the retry goes on to convergence; from the common start it
        // too fails, at iterate 1, with shifts up to 1e-1.
        let x = tutte(&normalized, settings.tutte_boundary).unwrap();
        let mut rec = Recorder::default();
        let shifted = newton(&problem, x, &Shifted, &settings.solver, &mut rec).unwrap();
        assert_eq!(shifted.stop_reason, StopReason::GradientTolerance);
        let base = settings.solver.linear.tikhonov;
        assert!(rec.rows[1].shift.is_some_and(|s| s > base), "{:?}", rec.rows[1].shift);
        assert!(rec.rows[1..].iter().all(|r| r.shift.is_some()));
    }
}
