//! The tolerance rules as events (docs/src/design/numerics.md, "Runs go to the target"): a
//! run whose rules are events has, up to each rule's first row, bit for bit the rows of the
//! run that rule ends, and records that row; it ends at its observer's target once a rule has
//! held, or at a stationary point, a breakdown or its budget.

use solvers::energy::EnergyKind;
use solvers::generate::{generate, generated_handles, generated_init};
use solvers::mesh::Mesh;
use solvers::solver::{
    Events, Flow, IterationRecord, Observer, Outcome, RuleUse, Settings, StopReason, StopRule, StopSettings,
};
use solvers::tasks::deform::{solve_deform, DeformSettings};
use solvers::tasks::param::{solve_param, ParamSettings};

/// Keeps the rows; a row at or below `target` (energy) is at the target.
struct Rows {
    rows: Vec<IterationRecord>,
    target: f64,
}

impl Observer for Rows {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        self.rows.push(r.clone());
        if r.energy <= self.target {
            Flow::AtTarget
        } else {
            Flow::Continue
        }
    }
}

/// What the iterates are, bit for bit (the times are the clock's).
fn bits(r: &IterationRecord) -> (usize, u64, u64, u64, usize, usize) {
    (r.iter, r.energy.to_bits(), r.grad_norm.to_bits(), r.step.to_bits(), r.flips, r.ls_evals)
}

/// A problem: how to solve it under stop rules `stop`, with an observer.
type Solve<'a> = Box<dyn Fn(StopSettings, &mut Rows) -> Outcome + 'a>;

fn param<'a>(mesh: &'a Mesh, energy: &str, solver: &'a str) -> Solve<'a> {
    let e = EnergyKind::default_for(energy).unwrap();
    Box::new(move |stop, rows| {
        let mut settings = ParamSettings::for_energy(&e);
        settings.solver = Settings { stop, ..settings.solver };
        solve_param(mesh, e, solver, &settings, rows).unwrap_or_else(|err| panic!("{solver}: {err}"))
    })
}

/// The papers' rule of a problem, ending runs; the same as events.
fn ending(stop: StopSettings) -> (StopSettings, StopSettings) {
    (StopSettings { rules: RuleUse::End, ..stop }, StopSettings { rules: RuleUse::Event, ..stop })
}

/// One problem under its rules three ways: ended by them; with them as events and no target
/// (to its stationary point, breakdown or budget); with them as events and a target.
fn check(name: &str, solve: &Solve, stop: StopSettings) {
    let (end, event) = ending(stop);
    let mut ended = Rows { rows: Vec::new(), target: f64::NEG_INFINITY };
    let stopped = solve(end, &mut ended);
    let mut on = Rows { rows: Vec::new(), target: f64::NEG_INFINITY };
    let went_on = solve(event, &mut on);
    assert_eq!(stopped.events, went_on.events.clone_until(stopped.iterations), "{name}: the events so far");
    let k = stopped.iterations;
    let a: Vec<_> = ended.rows.iter().map(bits).collect();
    let b: Vec<_> = on.rows[..=k].iter().map(bits).collect();
    assert_eq!(a, b, "{name}: the rows up to where the rules ended the run");
    match StopRule::ALL.into_iter().find(|r| r.stop_reason() == stopped.stop_reason) {
        // The rule that ended the first run held first at its last row in the second.
        Some(rule) => assert_eq!(went_on.events.of(rule), Some(k), "{name}: {:?}", went_on.events),
        // Ended otherwise before any rule held: the same end either way.
        None => assert_eq!(
            (&went_on.stop_reason, went_on.iterations),
            (&stopped.stop_reason, k),
            "{name}: the same end before the rules"
        ),
    }
    // Each rule alone ends a run at its event.
    for r in StopRule::ALL.into_iter().filter(|r| stop_has(&stop, *r)) {
        let Some(j) = went_on.events.of(r) else { continue };
        let only = StopSettings {
            grad_tol: if r == StopRule::GradientTolerance { stop.grad_tol } else { 0.0 },
            energy_decrease_tol: if r == StopRule::EnergyDecrease { stop.energy_decrease_tol } else { 0.0 },
            ..end
        };
        let alone = solve(only, &mut Rows { rows: Vec::new(), target: f64::NEG_INFINITY });
        assert_eq!((alone.stop_reason.clone(), alone.iterations), (r.stop_reason(), j), "{name}: {r:?} alone");
    }
    assert!(
        !went_on.stop_reason.is_converged() && went_on.stop_reason != StopReason::Target,
        "{name}: no target, so a stationary point, a breakdown or the budget: {:?}",
        went_on.stop_reason
    );
    let first_event = went_on.events.first().map(|(_, k)| k);
    // A target the run passes after its first event: it ends at the first row that passes it
    // once a rule has held, on the same rows.
    if let Some(first) = first_event.filter(|&f| went_on.iterations > f + 1) {
        let target = on.rows[first + 1].energy;
        let mut to = Rows { rows: Vec::new(), target };
        let reached = solve(event, &mut to);
        let end = on.rows.iter().position(|r| r.energy <= target).unwrap().max(first);
        assert_eq!((reached.stop_reason, reached.iterations), (StopReason::Target, end), "{name}");
        assert_eq!(reached.events, went_on.events.clone_until(end), "{name}");
        let c: Vec<_> = to.rows.iter().map(bits).collect();
        let d: Vec<_> = on.rows[..=end].iter().map(bits).collect();
        assert_eq!(c, d, "{name}: the rows to the target");
    }
    // A target from the start waits for a rule: the run ends where the first of them holds.
    let waited = solve(event, &mut Rows { rows: Vec::new(), target: f64::INFINITY });
    match first_event {
        Some(first) => assert_eq!((waited.stop_reason, waited.iterations), (StopReason::Target, first), "{name}"),
        None => {
            assert_eq!((waited.stop_reason, waited.iterations), (went_on.stop_reason, went_on.iterations), "{name}")
        }
    }
}

/// The events up to row `k` (those of a run ended there).
trait Until {
    fn clone_until(&self, k: usize) -> Events;
}

impl Until for Events {
    fn clone_until(&self, k: usize) -> Events {
        Events {
            grad_tol: self.grad_tol.filter(|&j| j <= k),
            energy_decrease: self.energy_decrease.filter(|&j| j <= k),
        }
    }
}

fn stop_has(stop: &StopSettings, rule: StopRule) -> bool {
    stop.enabled().any(|r| r == rule)
}

/// The papers' rules of `param` (1e-3, SARAP's decrease) on a small generated mesh, over the
/// method families: Newton with each projection, composite majorization, the first-order
/// proxies, L-BFGS, AQP, truncated Newton.
#[test]
fn param_rules_are_events_on_the_trajectory_a_stopped_run_has() {
    let mesh = generate("bumpy_1k").unwrap();
    let solvers = ["kp-newton", "fp-newton-6x6", "pn-abs", "cm", "slim", "akvf", "lbfgs", "aqp", "kp-newton-cg"];
    for energy in ["sd", "sarap", "bconf"] {
        let e = EnergyKind::default_for(energy).unwrap();
        let stop = ParamSettings::for_energy(&e).solver.stop;
        for solver in solvers {
            let skip = solvers::tasks::catalogue::lookup(solver, solvers::tasks::Task::Param).unwrap().skip_reason(
                solvers::tasks::Task::Param,
                &e,
                &Default::default(),
            );
            if skip.is_some() {
                continue;
            }
            let stop = StopSettings { max_iters: 300, ..stop };
            check(&format!("bumpy_1k {energy} {solver}"), &param(&mesh, energy, solver), stop);
        }
    }
}

/// `deform` with both of its rules on (the paper's decrease and the default gradient rule):
/// each is its own event, the stop is the first of them.
#[test]
fn deform_rules_are_events_each_at_its_own_row() {
    let bar = generate("planar_bar_2k").unwrap();
    let handles = generated_handles("planar_bar_2k").unwrap();
    let init = generated_init("planar_bar_2k");
    for energy in ["sd", "nh"] {
        let e = EnergyKind::default_for(energy).unwrap();
        for solver in ["kp-newton", "lbfgs"] {
            let solve: Solve = Box::new(|stop, rows| {
                let mut settings = DeformSettings::default();
                settings.solver.stop = stop;
                solve_deform(&bar, &handles, init.as_deref(), e, solver, &settings, rows).unwrap()
            });
            let stop =
                StopSettings { energy_decrease_tol: 1e-6, max_iters: 400, ..DeformSettings::default().solver.stop };
            check(&format!("planar_bar_2k {energy} {solver}"), &solve, stop);
        }
    }
}
