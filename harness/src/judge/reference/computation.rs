//! Computing a reference minimum and its certificate (the book's numerics page, "Reference
//! minima").
//!
//! The energies here are not convex: from one start, methods of different families stop at
//! different minima (on `finger_thin_1k` SD, KP-Newton at 4.2019 and AQP at 4.1880, both with
//! `|grad|` below 1e-5). So a reference is the best of a portfolio: each of [`PORTFOLIO`] from
//! the common start with a budget of [`BUDGET`] iterations (as large as any committed config's
//! `max_iters`; a solve stops early once it stalls, [`STALL_WINDOW`]), then the lowest map
//! polished by KP-Newton, and certified:
//!
//! - a smooth energy ([`CertificateRule::Stationary`]): `|grad| <=` [`STALL_GRAD`] at the map
//!   (a line search blocked by the barrier far from a minimum is not one), and neither a
//!   KP-Newton polish nor an L-BFGS polish (another family) of [`WINDOW`] iterations lowers the
//!   energy by more than [`CERTIFY_TOL`] `* A`;
//! - SARAP, not differentiable at conformal maps so its gradient need not vanish
//!   ([`CertificateRule::Stalled`]): neither polish lowers the energy by more than
//!   `CERTIFY_TOL * A` over [`LONG_WINDOW`] iterations each.
//!
//! A polish that goes lower replaces the map and the certificate is tried again (at most
//! [`ROUNDS`] times). `A` is the accuracy scale of the verdict (`convergence::accuracy_scale`),
//! so a certified `E*` is within a hundredth of the default tightest target of what two
//! methods can find from it.

use super::entry::{Certificate, CertificateRule, Polish, ProvenanceStep, Reference, StepKind};
use crate::convergence::accuracy_scale;
use crate::judge::problem::Problem;
use crate::plan::Task;
use anyhow::{bail, Result};
use solvers::solver::{Flow, IterationRecord, Observer, Outcome, StopReason, StopSettings};
use std::sync::atomic::{AtomicBool, Ordering};

/// The methods a reference is the best of, each from the common start: KP-Newton, L-BFGS
/// with the Laplacian (another family, which finds lower minima on the thin shapes) and AQP
/// where it is defined.
pub const PORTFOLIO: [&str; 3] = ["kp-newton", "lbfgs-laplacian", "aqp"];

/// Iterations of each portfolio solve and of the polish: at least any committed config's
/// `max_iters` (tested), so a run of a batch cannot go past the reference's budget.
pub const BUDGET: usize = 5000;

/// Iterations of the polish from the portfolio's best (it stops at Newton's floor, or when it
/// stalls, long before on the smooth energies).
pub const POLISH_BUDGET: usize = 1000;

/// The polish (Newton) and the second method of the certificate (another family).
pub const POLISH: &str = "kp-newton";
pub const SECOND: &str = "lbfgs-laplacian";

/// The authalic task's methods: the safeguarded AEM-CG (Armijo and fold guard) and the
/// faithful one from the start, the safeguarded one polishes, SEM's fixed point (another
/// family) is the certificate's second method.
pub const AUTHALIC_PORTFOLIO: [&str; 2] = ["aem-cg-safe", "aem-cg"];
pub const AUTHALIC_POLISH: &str = "aem-cg-safe";
pub const AUTHALIC_SECOND: &str = "sem";

/// The polish of `problem`'s task (the reference's, and the one that confirms another minimum).
pub fn polisher(problem: &Problem) -> &'static str {
    methods(problem).1
}

/// The portfolio, the polish and the certificate's second method of `problem`'s task.
fn methods(problem: &Problem) -> (&'static [&'static str], &'static str, &'static str) {
    match problem.objective {
        crate::judge::problem::Objective::Map { .. } => (&PORTFOLIO, POLISH, SECOND),
        crate::judge::problem::Objective::Authalic { .. } => (&AUTHALIC_PORTFOLIO, AUTHALIC_POLISH, AUTHALIC_SECOND),
    }
}

/// Iterations of each certifying polish for a smooth energy, and for SARAP's.
pub const WINDOW: usize = 200;
pub const LONG_WINDOW: usize = 500;

/// The largest decrease a certifying polish may find, relative to the accuracy scale `A`.
pub const CERTIFY_TOL: f64 = 1e-8;

/// The gradient norm above which a smooth energy's Newton floor is a stall, not a minimum.
pub const STALL_GRAD: f64 = 1e-4;

/// Certificate attempts (a polish that goes lower starts the next).
pub const ROUNDS: usize = 3;

/// A tight rule: no energy-decrease rule, the gradient to the floating-point floor.
fn tight(max_iters: usize) -> StopSettings {
    StopSettings::rules_only(1e-12, 0.0, max_iters)
}

/// Iterations over which a portfolio solve or a polish must lower the energy by more than the
/// certificate's tolerance to go on: slower, it has found its basin, and the polish and the
/// certificate (which looks for exactly such a decrease) take it from there.
pub const STALL_WINDOW: usize = 100;

/// Stops a solve when the batch is interrupted, or (`stall`) when it has stalled: the last
/// [`STALL_WINDOW`] iterations lowered the energy by less than `CERTIFY_TOL` of the accuracy
/// scale.
pub struct Watch<'a> {
    interrupt: &'a AtomicBool,
    /// The energy's isometry value (`None`: no stall rule).
    stall_ideal: Option<f64>,
    energies: Vec<f64>,
    stalled: bool,
}

impl<'a> Watch<'a> {
    pub fn new(interrupt: &'a AtomicBool, stall_ideal: Option<f64>) -> Watch<'a> {
        Watch { interrupt, stall_ideal, energies: Vec::new(), stalled: false }
    }
}

impl Observer for Watch<'_> {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        if self.interrupt.load(Ordering::Relaxed) {
            return Flow::Stop;
        }
        if let Some(ideal) = self.stall_ideal {
            self.energies.push(r.energy);
            let n = self.energies.len();
            if n > STALL_WINDOW && r.energy.is_finite() {
                let decrease = self.energies[n - 1 - STALL_WINDOW] - r.energy;
                if decrease < CERTIFY_TOL * accuracy_scale(r.energy, ideal) {
                    self.stalled = true;
                    return Flow::Stop;
                }
            }
        }
        Flow::Continue
    }
}

/// A map with its energy, as a step of the provenance found it.
pub struct Found {
    pub x: Vec<f64>,
    pub energy: f64,
    pub steps: Vec<ProvenanceStep>,
}

/// A solve of `solver` from `x` (`from` names it), as a step; its map when it ended without
/// flips at a finite energy.
fn solve(
    problem: &Problem,
    kind: StepKind,
    solver: &str,
    from: &str,
    x: Vec<f64>,
    max_iters: usize,
    interrupt: &AtomicBool,
) -> Result<(ProvenanceStep, Option<Vec<f64>>, StopReason)> {
    // The certifying polishes run their whole window: a stall is what they look for.
    let stall = (kind != StepKind::Certify).then_some(problem.ideal);
    let mut watch = Watch::new(interrupt, stall);
    let out: Outcome = problem.solve_from(solver, x, tight(max_iters), &mut watch)?;
    if interrupt.load(Ordering::Relaxed) {
        bail!("interrupted");
    }
    let m = problem.measure(&out.x);
    let stop_reason =
        if watch.stalled { format!("stalled ({STALL_WINDOW} iterations)") } else { out.stop_reason.as_str().into() };
    let step = ProvenanceStep {
        what: kind,
        solver: solver.into(),
        from: from.into(),
        iterations: out.iterations,
        stop_reason,
        energy: m.energy,
        grad_norm: m.grad_norm,
        batch: None,
    };
    let usable = m.flips == 0 && m.energy.is_finite();
    Ok((step, usable.then_some(out.x), out.stop_reason))
}

/// The best of the portfolio from the common start, then polished: the map a new reference
/// is made from. `notice` says what runs (the solves can take minutes).
pub fn search(problem: &Problem, notice: &dyn Fn(&str), interrupt: &AtomicBool) -> Result<Found> {
    let mut best: Option<Found> = None;
    let mut steps = Vec::new();
    let (portfolio, _, _) = methods(problem);
    for solver in portfolio.iter().filter(|s| problem.defines(s)) {
        notice(&format!("{solver} from the common start (at most {BUDGET} iterations)"));
        let (step, x, _) =
            solve(problem, StepKind::Portfolio, solver, "common start", problem.x0.clone(), BUDGET, interrupt)?;
        let energy = step.energy;
        steps.push(step);
        if let Some(x) = x {
            if best.as_ref().is_none_or(|b| energy < b.energy) {
                best = Some(Found { x, energy, steps: Vec::new() });
            }
        }
    }
    let Some(mut best) = best else {
        bail!("no method of the portfolio ended without flips ({})", steps_text(&steps));
    };
    best.steps = steps;
    polish(problem, best, notice, interrupt)
}

/// Polish `found` with Newton ([`POLISH`], [`POLISH_BUDGET`] iterations), keeping the lower map.
pub fn polish(problem: &Problem, mut found: Found, notice: &dyn Fn(&str), interrupt: &AtomicBool) -> Result<Found> {
    let (_, polisher, _) = methods(problem);
    notice(&format!("{polisher} polish from {:.12}", found.energy));
    let (step, x, _) =
        solve(problem, StepKind::Polish, polisher, "the kept map", found.x.clone(), POLISH_BUDGET, interrupt)?;
    let energy = step.energy;
    found.steps.push(step);
    if let Some(x) = x.filter(|_| energy < found.energy) {
        (found.x, found.energy) = (x, energy);
    }
    Ok(found)
}

/// Certify `found` (polishing it further where a certifying polish goes lower) and make the
/// reference entry `base` describes (its key, dataset, task, energy; the map's name and
/// checksum, `E*` and `|grad|` are set here from the map itself).
pub fn certify(
    problem: &Problem,
    mut found: Found,
    base: Reference,
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<(Reference, Vec<f64>)> {
    let rule = if problem.smooth() { CertificateRule::Stationary } else { CertificateRule::Stalled };
    let (_, polisher, second) = methods(problem);
    let window = match rule {
        CertificateRule::Stationary => WINDOW,
        CertificateRule::Stalled => LONG_WINDOW,
    };
    let mut certificate = None;
    for round in 0..ROUNDS {
        let tolerance = CERTIFY_TOL * accuracy_scale(found.energy, problem.ideal);
        notice(&format!("certifying {:.12} ({polisher} and {second}, {window} iterations each)", found.energy));
        let mut polishes = Vec::new();
        let mut lower: Option<(Vec<f64>, f64, ProvenanceStep)> = None;
        for solver in [polisher, second] {
            let (step, x, _) =
                solve(problem, StepKind::Certify, solver, "the kept map", found.x.clone(), window, interrupt)?;
            let decrease = found.energy - step.energy;
            polishes.push(Polish {
                solver: solver.into(),
                iterations: step.iterations,
                stop_reason: step.stop_reason.clone(),
                decrease: if decrease.is_finite() { decrease } else { 0.0 },
            });
            if let Some(x) = x.filter(|_| decrease > tolerance) {
                if lower.as_ref().is_none_or(|l| step.energy < l.1) {
                    lower = Some((x, step.energy, step));
                }
            }
        }
        let grad = problem.measure(&found.x).grad_norm.unwrap_or(f64::INFINITY);
        let (certified, reason) = match (&lower, rule) {
            (Some((_, e, _)), _) => (false, format!("a certifying polish went lower, to {e:.12}")),
            (None, CertificateRule::Stationary) if grad > STALL_GRAD => {
                (false, format!("|grad| = {grad:.2e} where the polishes stall, above {STALL_GRAD:e}: not a minimum"))
            }
            (None, CertificateRule::Stationary) => (
                true,
                format!(
                    "stationary: |grad| = {grad:.2e}, and neither {polisher} nor {second} lowers E by more than \
                     {tolerance:.1e} in {window} iterations"
                ),
            ),
            (None, CertificateRule::Stalled) => {
                (true, format!("stalled: neither polish lowers E by more than {tolerance:.1e} in {window} iterations"))
            }
        };
        certificate = Some(Certificate { rule, certified, reason, tolerance, polishes });
        match lower {
            Some((x, energy, mut step)) if round + 1 < ROUNDS => {
                step.what = StepKind::Polish;
                found.steps.push(step);
                (found.x, found.energy) = (x, energy);
                found = polish(problem, found, notice, interrupt)?;
            }
            _ => break,
        }
    }
    let Some(certificate) = certificate else { bail!("no certificate round ran") };
    let m = problem.measure(&found.x);
    let mut r = base;
    r.e_star = m.energy;
    r.grad_norm = m.grad_norm.unwrap_or(f64::INFINITY);
    r.ideal = problem.ideal;
    r.start_energy = problem.e0;
    r.start = problem.start.as_str().into();
    r.map_checksum = super::store::map_checksum(&found.x);
    r.map = super::store::map_name(&r);
    r.provenance = found.steps;
    r.certificate = certificate;
    Ok((r, found.x))
}

/// Compute the reference of `problem` ([`search`], then [`certify`]): the entry and its map.
pub fn compute(
    problem: &Problem,
    key: &str,
    dataset: &str,
    energy: &str,
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<(Reference, Vec<f64>)> {
    let found = search(problem, notice, interrupt)?;
    certify(problem, found, blank(key, dataset, problem.task(), energy), notice, interrupt)
}

/// An entry of `key` whose values [`certify`] fills.
pub fn blank(key: &str, dataset: &str, task: Task, energy: &str) -> Reference {
    Reference {
        key: key.into(),
        dataset: dataset.into(),
        task,
        energy: energy.into(),
        e_star: f64::NAN,
        ideal: f64::NAN,
        start_energy: f64::NAN,
        start: String::new(),
        grad_norm: f64::NAN,
        map: String::new(),
        map_checksum: String::new(),
        provenance: Vec::new(),
        certificate: Certificate {
            rule: CertificateRule::Stationary,
            certified: false,
            reason: String::new(),
            tolerance: 0.0,
            polishes: Vec::new(),
        },
    }
}

/// The steps in one line, for an error.
fn steps_text(steps: &[ProvenanceStep]) -> String {
    steps
        .iter()
        .map(|s| format!("{}: {} after {}", s.solver, s.stop_reason, s.iterations))
        .collect::<Vec<_>>()
        .join("; ")
}
