//! The batch in one count: every run in exactly one class ([`Class`]), so that the first
//! screen, its roll-up and its list of problems say one set of numbers. Solved runs are those
//! at their energy's tightest target; a run not solved is counted by the reason it ended, in
//! words with its value ("stalled: no decrease in 50 iterations"); runs that could not run
//! failed; runs not run were skipped, by the solver's definition or for want of something on
//! the machine (an external solver's package: an environment failure, named). Apart: runs of
//! problems solved at their start (the common start within round-off of `E*`: they say
//! nothing of a solver, and the tables' means and profiles leave them out) and runs of the
//! solvers the config expects to fail.

use crate::external::probe::Probe;
use crate::judge::verdict::Verdict;
use crate::report::batch::Batch;
use crate::report::select::counted;
use crate::run_folder::{RunStop, Status, SummaryRow};
use solvers::solver::StopReason;

/// Why a run that ran was not solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// The harness's verdict, not `solved`.
    Verdict(Verdict),
    /// A fixed-budget protocol's run (`authalic`'s 100 iterations) above the target.
    FixedBudget,
    /// No reference minimum to judge it by.
    NotJudged,
}

/// The one class of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Not run: outside the solver's definition.
    NotDefined,
    /// Not run: the machine lacks what an external solver needs (its probe failed).
    Environment,
    /// A solver the config expects to fail (`expected_to_fail`), whatever became of the run.
    Expected,
    /// The run could not run (an error).
    Failed,
    /// A problem solved at its start.
    Trivial,
    /// Solved: at its energy's tightest target, no flipped triangle.
    Solved,
    NotSolved(Reason),
}

/// The class of run `r` of a batch.
pub fn class(r: &SummaryRow, batch: &Batch) -> Class {
    if r.status == Status::Skipped {
        let env = batch.external.iter().any(|p| p.name == r.solver && p.unavailable.as_deref() == Some(&r.error));
        return if env { Class::Environment } else { Class::NotDefined };
    }
    if batch.expected_to_fail.contains(&r.solver) {
        return Class::Expected;
    }
    if r.status == Status::Failed {
        return Class::Failed;
    }
    if r.trivial() {
        return Class::Trivial;
    }
    match (r.verdict, r.status) {
        (Some(Verdict::Solved), _) => Class::Solved,
        (Some(_), Status::Budget) => Class::NotSolved(Reason::FixedBudget),
        (Some(v), _) => Class::NotSolved(Reason::Verdict(v)),
        (None, Status::Ok) => Class::Solved,
        (None, _) => Class::NotSolved(Reason::NotJudged),
    }
}

/// Whether a run counts among the problems of the morning: failed or not solved, of a solver
/// not expected to fail, on a problem not solved at its start.
pub fn is_problem(r: &SummaryRow, batch: &Batch) -> bool {
    matches!(class(r, batch), Class::Failed | Class::NotSolved(_))
}

/// The batch's count.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Count {
    pub runs: usize,
    pub solved: usize,
    /// Per target (loosest first), the runs counted as solved or not solved that reached it.
    pub reached: Vec<(f64, usize)>,
    /// Each way of not being solved in words, with its count, the most frequent first.
    pub not_solved: Vec<(String, usize)>,
    pub failed: usize,
    pub not_defined: usize,
    /// Per external solver the machine could not run: its runs and why.
    pub environment: Vec<(String, usize, String)>,
    /// Runs on problems solved at their start, and those problems.
    pub trivial: usize,
    pub trivial_problems: Vec<String>,
    /// Runs of the solvers expected to fail, and how many of them were solved.
    pub expected: usize,
    pub expected_solved: usize,
}

impl Count {
    /// The count of `rows`.
    pub fn of(rows: &[SummaryRow], batch: &Batch) -> Count {
        let mut c = Count { runs: rows.len(), ..Count::default() };
        let mut reasons: Vec<String> = Vec::new();
        let mut environment: Vec<&str> = Vec::new();
        let mut taus: Vec<f64> = Vec::new();
        for r in rows {
            match class(r, batch) {
                Class::NotDefined => c.not_defined += 1,
                Class::Environment => environment.push(&r.solver),
                Class::Expected => {
                    c.expected += 1;
                    c.expected_solved += usize::from(r.verdict == Some(Verdict::Solved));
                }
                Class::Failed => c.failed += 1,
                Class::Trivial => {
                    c.trivial += 1;
                    let problem = format!("{} {}", r.dataset, r.energy);
                    if !c.trivial_problems.contains(&problem) {
                        c.trivial_problems.push(problem);
                    }
                }
                class @ (Class::Solved | Class::NotSolved(_)) => {
                    if let Class::NotSolved(reason) = class {
                        reasons.push(words(reason, r, batch));
                    } else {
                        c.solved += 1;
                    }
                    for t in r.to_targets.iter().filter(|t| t.iters.is_some()) {
                        taus.push(t.tau);
                    }
                }
            }
        }
        let mut reached = counted(taus);
        reached.sort_by(|a, b| b.0.total_cmp(&a.0));
        c.reached = reached;
        let mut not_solved = counted(reasons);
        not_solved.sort_by_key(|(_, n)| std::cmp::Reverse(*n));
        c.not_solved = not_solved;
        c.environment = counted(environment)
            .into_iter()
            .map(|(solver, n)| {
                let why = batch.external.iter().find(|p: &&Probe| p.name == solver);
                (solver.to_string(), n, why.and_then(|p| p.unavailable.clone()).unwrap_or_default())
            })
            .collect();
        c
    }

    /// Runs not solved.
    pub fn not_solved_runs(&self) -> usize {
        self.not_solved.iter().map(|(_, n)| n).sum()
    }

    /// Runs skipped, by definition or for want of something on the machine.
    pub fn skipped(&self) -> usize {
        self.not_defined + self.environment.iter().map(|e| e.1).sum::<usize>()
    }

    /// Runs apart from the count of the others: on problems solved at their start, and of
    /// solvers expected to fail.
    pub fn apart(&self) -> usize {
        self.trivial + self.expected
    }
}

/// How a run that was not solved ended, in words with the value of the end where it has one:
/// `stalled: no decrease in 50 iterations`. One string per way, so runs that ended alike count
/// together.
fn words(reason: Reason, r: &SummaryRow, batch: &Batch) -> String {
    let stop = r.stop_reason.as_ref().and_then(RunStop::solver);
    let settings = batch.stop.get(&r.energy);
    let cap = batch.max_iters.get(&r.energy).map_or(String::from("the iteration cap"), |n| format!("{n} iterations"));
    match reason {
        Reason::NotJudged => "not judged (no reference minimum)".into(),
        Reason::FixedBudget => format!("ran its fixed budget ({cap}) above the target"),
        Reason::Verdict(v) => match (v, stop) {
            (Verdict::Unfinished, Some(StopReason::Timeout)) => match batch.timeout_s {
                Some(t) => format!("out of time: {t} s"),
                None => "out of time".into(),
            },
            (Verdict::Unfinished, _) => format!("out of budget: {cap}"),
            (Verdict::Stalled, Some(StopReason::GradientFloor)) => match settings.and_then(|s| s.grad_floor) {
                Some(f) => format!("stalled: |grad| <= {f:e}, far from the target"),
                None => "stalled at the gradient floor".into(),
            },
            (Verdict::Stalled, Some(StopReason::RoundOff)) => {
                "stalled: the line search's model predicts a decrease below round-off".into()
            }
            (Verdict::Stalled, _) => match settings.and_then(|s| s.stall_window) {
                Some(w) => format!("stalled: no decrease in {w} iterations"),
                None => "stalled: no decrease".into(),
            },
            (Verdict::OtherMinimum, _) => "at another minimum (a polish from its map stayed there)".into(),
            (Verdict::BrokeDown, Some(s)) => format!("broke down: {}", breakdown(s)),
            (Verdict::BrokeDown, None) => "broke down".into(),
            (Verdict::Flipped, _) => "its map flips faces".into(),
            (Verdict::StoppedAboveTarget, Some(StopReason::Target)) => {
                "stopped at the target of a reference this batch lowered".into()
            }
            (Verdict::StoppedAboveTarget, Some(s)) => format!("stopped above the target by its own rule ({s})"),
            (Verdict::StoppedAboveTarget, None) => "stopped above the target by its own rule".into(),
            (Verdict::Solved, _) => "solved".into(),
        },
    }
}

/// A breakdown in words.
fn breakdown(s: &StopReason) -> &'static str {
    match s {
        StopReason::LineSearchFailed => "the line search found no decrease",
        StopReason::LinearSolveFailed(_) => "a factorization failed",
        StopReason::NotDescent => "not a descent direction",
        StopReason::NonFinite(_) => "a value became non-finite",
        StopReason::EnergyIncreased => "a step raised the energy",
        _ => s.as_str(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::run_folder::meta::Stop;
    use crate::run_folder::summary::ToTarget;

    fn row(solver: &str, status: Status, verdict: Option<Verdict>, stop: Option<StopReason>) -> SummaryRow {
        SummaryRow {
            dataset: "d".into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            status,
            verdict,
            stop_reason: stop.map(RunStop::Solver),
            start_energy: Some(10.0),
            ref_energy: Some(2.0),
            to_targets: vec![
                ToTarget { tau: 1e-3, iters: Some(3), time_s: Some(0.1) },
                ToTarget { tau: 1e-6, iters: (verdict == Some(Verdict::Solved)).then_some(5), time_s: None },
            ],
            ..Default::default()
        }
    }

    fn batch() -> Batch {
        let probe = Probe {
            name: "igl-slim".into(),
            command: vec![],
            version: None,
            unavailable: Some("No module named 'igl'".into()),
        };
        Batch {
            max_iters: [("sd".to_string(), 1000)].into(),
            stop: [("sd".to_string(), Stop { stall_window: Some(50), grad_floor: Some(1e-10), ..Stop::default() })]
                .into(),
            external: vec![probe],
            expected_to_fail: vec!["newton".into()],
            ..Batch::default()
        }
    }

    /// Every run in one class, the classes add up to the runs, each reason in words with its
    /// value; an environment failure named with its solver and why.
    #[test]
    fn every_run_is_counted_once_and_the_classes_add_up() {
        use StopReason::*;
        let ok = Some(Verdict::Solved);
        let nc = Status::NotConverged;
        let mut trivial = row("kp-newton", Status::Ok, ok, Some(Target));
        trivial.start_energy = Some(2.0);
        let mut env = row("igl-slim", Status::Skipped, None, None);
        env.error = "No module named 'igl'".into();
        let mut defined = row("igl-slim", Status::Skipped, None, None);
        defined.error = "igl-slim is an external solver of sd only".into();
        let rows = vec![
            row("kp-newton", Status::Ok, ok, Some(Target)),
            row("slim", nc, Some(Verdict::Unfinished), Some(MaxIterations)),
            row("aqp", nc, Some(Verdict::Stalled), Some(NoDecrease)),
            row("lbfgs", nc, Some(Verdict::Stalled), Some(NoDecrease)),
            row("akvf", nc, Some(Verdict::BrokeDown), Some(LineSearchFailed)),
            row("cm", Status::Failed, None, None),
            row("newton", nc, Some(Verdict::BrokeDown), Some(LinearSolveFailed(String::new()))),
            trivial,
            env,
            defined,
        ];
        let c = Count::of(&rows, &batch());
        assert_eq!((c.runs, c.solved, c.not_solved_runs(), c.failed, c.skipped(), c.apart()), (10, 1, 4, 1, 2, 2));
        assert_eq!(c.runs, c.solved + c.not_solved_runs() + c.failed + c.skipped() + c.apart());
        assert_eq!(
            c.not_solved,
            [
                ("stalled: no decrease in 50 iterations".to_string(), 2),
                ("out of budget: 1000 iterations".to_string(), 1),
                ("broke down: the line search found no decrease".to_string(), 1),
            ]
        );
        assert_eq!(c.reached, [(1e-3, 5), (1e-6, 1)]);
        assert_eq!(c.environment, [("igl-slim".to_string(), 1, "No module named 'igl'".to_string())]);
        assert_eq!(
            (c.trivial, c.trivial_problems.clone(), c.expected, c.expected_solved),
            (1, vec!["d sd".into()], 1, 0)
        );
        assert!(is_problem(&rows[1], &batch()) && is_problem(&rows[5], &batch()));
        assert!(!is_problem(&rows[6], &batch()) && !is_problem(&rows[7], &batch()) && !is_problem(&rows[0], &batch()));
    }
}
