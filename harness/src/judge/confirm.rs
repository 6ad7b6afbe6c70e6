//! After a run: what its final map says beyond its rows. A run that ended stationary, or with
//! a small gradient, above its tightest target may be at another local minimum, or merely slow in a flat
//! valley; a tight KP-Newton polish from its final map tells them apart (`polished_energy`: the
//! verdict claims `other_minimum` only when the polish stays above the target, having closed
//! at most `verdict::STAYED` of the gap). A run, or its polish,
//! that ends below `E*` is a candidate to lower the reference (`improve`).

use super::improve::{below, Candidate};
use super::problem::Problem;
use super::reference::{GroupReference, ProvenanceStep, StepKind};
use super::Yardstick;
use crate::convergence;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::SummaryRow;
use solvers::mesh::Mesh;
use solvers::solver::{Flow, IterationRecord, Observer, StopSettings};
use std::sync::atomic::{AtomicBool, Ordering};

/// The polish's iterations at most; its solver is the reference's polish of the task
/// (`computation::polisher`: `kp-newton`, `aem-cg-safe` for `authalic`).
pub const WINDOW: usize = 100;

/// Stops the polish once it is within `limit` (it went on towards `E*`: not another
/// minimum), or on an interrupt.
struct Until<'a> {
    limit: f64,
    interrupt: &'a AtomicBool,
}

impl Observer for Until<'_> {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        if r.energy <= self.limit || self.interrupt.load(Ordering::Relaxed) {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }
}

/// What the final map `x` of `run` (its row `summary`, before the judge) says: the energy a
/// polish reached when the run is a candidate for another minimum (farther than its
/// `tightest` target, the one it is judged at; `grad_tol` its gradient rule), and a candidate
/// to lower the reference.
#[allow(clippy::too_many_arguments)]
pub fn after_run(
    plan: &Plan,
    run: &PlannedRun,
    mesh: &Mesh,
    summary: &SummaryRow,
    x: Vec<f64>,
    group: Option<&GroupReference>,
    tightest: f64,
    interrupt: &AtomicBool,
) -> (Option<f64>, Option<Candidate>) {
    let (Some(group), Some(last)) = (group, summary.final_energy) else { return (None, None) };
    let Some(stick) = Yardstick::of(group) else { return (None, None) };
    if summary.flips != Some(0) || !last.is_finite() {
        return (None, None);
    }
    let run_step = ProvenanceStep {
        what: StepKind::Run,
        solver: run.solver.clone(),
        from: "common start".into(),
        iterations: summary.iterations.unwrap_or(0),
        stop_reason: summary.stop_column().into(),
        energy: last,
        grad_norm: summary.grad_norm,
        batch: None,
    };
    let candidate = |x: Vec<f64>, energy: f64, steps: Vec<ProvenanceStep>| Candidate {
        stem: run.stem.clone(),
        dataset: summary.dataset.clone(),
        energy_name: summary.energy.clone(),
        x,
        energy,
        steps,
    };
    if below(stick.e_star, last) {
        return (None, Some(candidate(x, last, vec![run_step])));
    }
    let span = stick.span(summary.init_energy.unwrap_or(last));
    let far = convergence::gap_on(last, stick.e_star, span) > tightest;
    let grad_tol = run.settings.stop().grad_tol;
    let small = grad_tol > 0.0 && summary.grad_norm.is_some_and(|g| g <= grad_tol);
    let stationary = summary.stop_reason.as_ref().and_then(|s| s.solver()).is_some_and(|s| s.is_stationary());
    if !(far && (small || stationary)) {
        return (None, None);
    }
    let Ok(problem) = Problem::with_mesh(plan, run, mesh.clone()) else { return (None, None) };
    let mut until = Until { limit: stick.e_star + tightest * span, interrupt };
    let stop = StopSettings::rules_only(1e-12, 0.0, WINDOW);
    let polisher = super::reference::computation::polisher(&problem);
    let Ok(out) = problem.solve_from(polisher, x, stop, &mut until) else { return (None, None) };
    let m = problem.measure(&out.x);
    if m.flips > 0 || !m.energy.is_finite() {
        return (None, None);
    }
    let lower = below(stick.e_star, m.energy).then(|| {
        let polish = ProvenanceStep {
            what: StepKind::Polish,
            solver: polisher.into(),
            from: format!("the final map of {}", run.stem),
            iterations: out.iterations,
            stop_reason: out.stop_reason.as_str().into(),
            energy: m.energy,
            grad_norm: m.grad_norm,
            batch: None,
        };
        candidate(out.x, m.energy, vec![run_step, polish])
    });
    (Some(m.energy), lower)
}
