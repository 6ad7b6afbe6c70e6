//! The harness judges the runs of `param` and `deform` batches: by the convergence test
//! (`crate::convergence`) against the group's reference minimum (`reference`), on the span
//! `min(E0 - E*, A)` from the common start's energy and the minimum's accuracy scale, each
//! run's verdict (`verdict`), its final gap, and its iterations and time to each target. A
//! run is `ok` when its final map is valid and within the tightest target, whatever its own
//! stop rule said. A run's verdict depends on its own rows and its group's reference only,
//! never on which other runs the batch has; `authalic` runs are judged alike, on `E_A`
//! (docs/src/reference/statuses.md).

pub mod confirm;
pub mod end;
pub mod improve;
pub mod problem;
pub mod reference;
pub mod verdict;

use crate::convergence::{self, Targets};
use crate::run_folder::summary::{RefSource, ToTarget};
use crate::run_folder::{read_run, Status, SummaryRow};
use anyhow::Result;
use reference::GroupReference;
use std::path::Path;
use verdict::{End, Facts, Verdict};

/// What a group's runs are measured against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Yardstick {
    pub e_star: f64,
    pub source: RefSource,
    /// Whether `E*` is certified (an uncertified one is marked wherever its verdicts appear).
    pub certified: bool,
    /// `E0`, the common start's energy (`None`: each run's own first row, for a folder
    /// written before it was recorded).
    pub e0: Option<f64>,
    /// `E_iso` (`None`: Moré and Wild's span alone, for such a folder).
    pub ideal: Option<f64>,
}

impl Yardstick {
    /// The span of a run whose own start's energy is `run_e0`.
    pub fn span(&self, run_e0: f64) -> f64 {
        let e0 = self.e0.unwrap_or(run_e0);
        match self.ideal {
            Some(ideal) => convergence::span(e0, self.e_star, ideal),
            None => (e0 - self.e_star).max(0.0),
        }
    }

    /// Whether energy `e` of a run whose own start's energy is `run_e0` passes the test at `tau`.
    pub fn passes(&self, e: f64, run_e0: f64, tau: f64) -> bool {
        convergence::passes(e, self.e_star, self.span(run_e0), tau)
    }

    /// Whether the problem is solved at its start: the common start within round-off of `E*`
    /// (exp-SD from the SD minimum of a developable mesh), so every run is solved at row 0.
    pub fn trivial(&self) -> bool {
        self.e0.is_some_and(|e0| convergence::trivial(e0, self.e_star))
    }

    /// The yardstick of a group with reference `g`, or `None` without an `E*`.
    pub fn of(g: &GroupReference) -> Option<Yardstick> {
        Some(Yardstick {
            e_star: g.e_star?,
            source: RefSource::Reference,
            certified: g.certified,
            e0: g.start_energy,
            ideal: g.ideal,
        })
    }
}

/// Judge the runs of `rows` (a whole batch) whose files are in `dir`, each group (dataset,
/// energy) against its reference in `references` at its energy's `targets` (loosest first);
/// a group without one (none could be computed) against the batch's best final energy without
/// flips, marked `ref_source = batch` and uncertified. `grad_tol` gives each energy's gradient
/// tolerance (the "small gradient" of [`Verdict::OtherMinimum`]). Sets `ref_energy`,
/// `ref_source`, `ref_certified`, `start_energy`, `ideal_energy`, `gap_scale`, `final_gap`,
/// `verdict`, the targets' iterations and times, the rules' times, and `status` (ok = solved).
pub fn judge_batch(
    dir: &Path,
    rows: &mut [SummaryRow],
    references: &[GroupReference],
    targets: &Targets,
    grad_tol: impl Fn(&str) -> Option<f64>,
) -> Result<()> {
    // Each run's energies and cumulative iteration times, for the runs that ran.
    let mut series: Vec<Option<(Vec<f64>, Vec<f64>)>> = Vec::with_capacity(rows.len());
    for r in rows.iter_mut() {
        let ran = r.status.ran();
        series.push(if ran {
            let file = read_run(dir, r)?;
            let t_cum: Vec<f64> = file.rows.iter().map(|x| x.t_cum_s).collect();
            rule_times(r, &t_cum);
            Some((file.rows.iter().map(|x| x.energy).collect(), t_cum))
        } else {
            None
        });
    }
    let mut groups: Vec<(String, String)> = Vec::new();
    for r in rows.iter() {
        if !groups.iter().any(|(d, e)| *d == r.dataset && *e == r.energy) {
            groups.push((r.dataset.clone(), r.energy.clone()));
        }
    }
    for (dataset, energy) in groups {
        let targets = targets.of(&energy);
        if targets.is_empty() {
            continue;
        }
        let members: Vec<usize> =
            (0..rows.len()).filter(|&i| rows[i].dataset == dataset && rows[i].energy == energy).collect();
        let group = references.iter().find(|g| g.dataset == dataset && g.energy == energy);
        let stick = match group.and_then(Yardstick::of) {
            Some(y) => y,
            None => {
                let best = members
                    .iter()
                    .filter(|&&i| series[i].is_some() && rows[i].flips == Some(0))
                    .filter_map(|&i| rows[i].final_energy.filter(|e| e.is_finite()))
                    .fold(f64::INFINITY, f64::min);
                if !best.is_finite() {
                    continue;
                }
                Yardstick {
                    e_star: best,
                    source: RefSource::Batch,
                    certified: false,
                    e0: group.and_then(|g| g.start_energy),
                    ideal: group.and_then(|g| g.ideal),
                }
            }
        };
        for &i in &members {
            let Some((energies, t_cum)) = &series[i] else { continue };
            let r = &mut rows[i];
            let (Some(&run_e0), Some(&last)) = (energies.first(), energies.last()) else { continue };
            let span = stick.span(run_e0);
            judge_run(r, energies, t_cum, &stick, span, last, targets, grad_tol(&r.energy));
        }
    }
    Ok(())
}

/// Judge one run whose rows' energies are `energies` (its final one `last`) against `stick` on
/// `span`.
#[allow(clippy::too_many_arguments)]
fn judge_run(
    r: &mut SummaryRow,
    energies: &[f64],
    t_cum: &[f64],
    stick: &Yardstick,
    span: f64,
    last: f64,
    targets: &[f64],
    grad_tol: Option<f64>,
) {
    let tightest = targets[targets.len() - 1];
    let e_star = stick.e_star;
    r.ref_energy = Some(e_star);
    r.ref_source = Some(stick.source);
    r.ref_certified = Some(stick.certified);
    r.start_energy = Some(stick.e0.unwrap_or(energies[0]));
    r.ideal_energy = stick.ideal;
    r.gap_scale = Some(span);
    let flips = r.flips.unwrap_or(0);
    let final_gap = convergence::gap_on(last, e_star, span);
    r.final_gap = Some(final_gap);
    // A target counts from the first row that passes it, when the final map is within it too.
    r.to_targets = targets
        .iter()
        .map(|&tau| {
            let within = flips == 0 && convergence::passes(last, e_star, span, tau);
            let k = within.then(|| convergence::first_reached(energies, e_star, span, tau)).flatten();
            let time_s = k.zip(r.time_s).and_then(|(k, t)| convergence::time_to(t, t_cum, k));
            ToTarget { tau, iters: k, time_s }
        })
        .collect();
    let small_gradient = grad_tol.zip(r.grad_norm).is_some_and(|(tol, g)| tol > 0.0 && g <= tol);
    let end = r.stop_reason.as_ref().and_then(|s| s.solver()).map_or(End::Budget, End::of);
    let v = verdict::judge(Facts {
        within: convergence::passes(last, e_star, span, tightest),
        flips,
        end,
        final_gap,
        small_gradient,
        polished_gap: r.polished_energy.map(|e| convergence::gap_on(e, e_star, span)),
        tightest,
    });
    r.verdict = Some(v);
    r.status = match v {
        Verdict::Solved => Status::Ok,
        _ if r.status == Status::Budget => Status::Budget,
        _ => Status::NotConverged,
    };
}

/// The time each rule's event came at: `time_s` less the iterations after it.
fn rule_times(r: &mut SummaryRow, t_cum: &[f64]) {
    let at = |k: Option<usize>| k.zip(r.time_s).and_then(|(k, t)| convergence::time_to(t, t_cum, k));
    r.rule_grad_tol_time_s = at(r.rule_grad_tol_iters);
    r.rule_energy_decrease_time_s = at(r.rule_energy_decrease_iters);
}

#[cfg(test)]
mod tests {
    use super::reference::Origin;
    use super::*;
    use crate::run_folder::{iteration_csv, iterations_csv, run_stem, RunStop};
    use solvers::solver::{IterationRecord, StopReason};

    /// A finished run of solver `s` through `energies`, its own rule saying `converged`, its
    /// per-iteration file written into `dir`.
    fn ran(dir: &Path, s: &str, energies: &[f64], converged: bool, grad_norm: f64) -> SummaryRow {
        ran_on(dir, "sd", s, energies, converged, grad_norm)
    }

    fn ran_on(dir: &Path, energy: &str, s: &str, energies: &[f64], converged: bool, grad_norm: f64) -> SummaryRow {
        let rows: Vec<IterationRecord> = energies
            .iter()
            .enumerate()
            .map(|(i, &e)| IterationRecord { iter: i, energy: e, t_cum_s: i as f64, ..Default::default() })
            .collect();
        let path = iterations_csv(dir, &run_stem("d", energy, s));
        std::fs::write(path, iteration_csv(&rows, 0.0, None, None).unwrap()).unwrap();
        SummaryRow {
            dataset: "d".into(),
            task: crate::plan::Task::Param,
            energy: energy.into(),
            solver: s.into(),
            iterations: Some(energies.len() - 1),
            converged,
            final_energy: energies.last().copied(),
            grad_norm: Some(grad_norm),
            time_s: Some(0.5 + (energies.len() - 1) as f64),
            flips: Some(0),
            stop_reason: Some(RunStop::Solver(match converged {
                true => StopReason::GradientTolerance,
                false => StopReason::MaxIterations,
            })),
            status: if converged { Status::Ok } else { Status::NotConverged },
            ..Default::default()
        }
    }

    /// An empty run folder (with its `runs/`) for [`ran`]'s files.
    fn run_folder() -> tempfile::TempDir {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir(tmp.path().join("runs")).unwrap();
        tmp
    }

    /// The group "d sd" with reference `e_star`, common start `e0` and isometry value `ideal`.
    fn group(e_star: f64, e0: f64, ideal: f64) -> Vec<GroupReference> {
        vec![GroupReference {
            dataset: "d".into(),
            energy: "sd".into(),
            key: Some("k".into()),
            e_star: Some(e_star),
            origin: Origin::Store,
            note: None,
            start_energy: Some(e0),
            ideal: Some(ideal),
            certified: true,
            certificate: Some("stationary".into()),
        }]
    }

    fn targets() -> Targets {
        Targets::uniform(vec![1e-3, 1e-6])
    }

    fn verdicts(rows: &[SummaryRow]) -> Vec<(Status, Verdict)> {
        rows.iter().map(|r| (r.status, r.verdict.unwrap())).collect()
    }

    /// A run whose own rule stopped it above the target is not ok, a run that never said
    /// converged but ended within it is; iterations and times to each target are counted
    /// from the start. Here the span is the start's distance, 8 (the accuracy scale, 100, is
    /// larger).
    #[test]
    fn the_harness_decides_not_the_solvers_own_rule() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let mut rows = vec![
            // E0 = 10, E* = 2: 1e-3 needs E <= 2.008, 1e-6 needs E <= 2.000008
            ran(dir, "a", &[10.0, 3.0, 2.005, 2.000001], true, 1e-4),
            ran(dir, "b", &[10.0, 2.5, 2.005], true, 5e-4),
            ran(dir, "c", &[10.0, 4.0, 2.0000001], false, 1e-2),
            ran(dir, "e", &[10.0, 9.0], false, 1.0),
        ];
        judge_batch(dir, &mut rows, &group(2.0, 10.0, -98.0), &targets(), tol).unwrap();
        assert_eq!(
            verdicts(&rows),
            [
                (Status::Ok, Verdict::Solved),
                (Status::NotConverged, Verdict::StoppedAboveTarget),
                (Status::Ok, Verdict::Solved),
                (Status::NotConverged, Verdict::Unfinished),
            ]
        );
        assert!(rows.iter().all(|r| r.ref_energy == Some(2.0)
            && r.ref_source == Some(RefSource::Reference)
            && r.gap_scale == Some(8.0)
            && r.ref_certified == Some(true)
            && r.start_energy == Some(10.0)));
        // a: 1e-3 at iteration 2 (0.5 s setup + 2 s), 1e-6 at 3
        let to = |r: &SummaryRow| r.to_targets.iter().map(|t| (t.iters, t.time_s)).collect::<Vec<_>>();
        assert_eq!(to(&rows[0]), [(Some(2), Some(2.5)), (Some(3), Some(3.5))]);
        assert_eq!(to(&rows[1]), [(Some(2), Some(2.5)), (None, None)]);
        assert!((rows[1].final_gap.unwrap() - 0.005 / 8.0).abs() < 1e-15);
        assert_eq!(to(&rows[3]), [(None, None), (None, None)]);
    }

    /// finger_thin_1k SD: E0 = 1.26e7 and E* = 4.188, E_iso = 2. KP-Newton's 4.2020 was
    /// solved at 1e-6 measured from E0; on the accuracy scale 2.188 it is 6.4e-3 above: not
    /// even at 1e-3. With a small gradient it is another minimum once a polish stays there,
    /// else stopped above the target.
    #[test]
    fn solved_means_the_same_accuracy_whatever_the_start() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let judge = |polished: Option<f64>| {
            let mut kp = ran(dir, "kp", &[1.26e7, 5.0, 4.2020], true, 9e-4);
            kp.polished_energy = polished;
            let mut rows = vec![kp, ran(dir, "aqp", &[1.26e7, 5.0, 4.188 + 2e-6], true, 9e-4)];
            judge_batch(dir, &mut rows, &group(4.188, 1.26e7, 2.0), &targets(), tol).unwrap();
            rows
        };
        let rows = judge(None);
        assert!((rows[0].gap_scale.unwrap() - 2.188).abs() < 1e-12);
        assert!((rows[0].final_gap.unwrap() - 0.014 / 2.188).abs() < 1e-9);
        assert_eq!(
            verdicts(&rows),
            [(Status::NotConverged, Verdict::StoppedAboveTarget), (Status::Ok, Verdict::Solved)]
        );
        assert!(rows[0].to_targets.iter().all(|t| t.iters.is_none()));
        assert_eq!(judge(Some(4.201999)).first().and_then(|r| r.verdict), Some(Verdict::OtherMinimum));
        // a polish that went on down: not another minimum
        assert_eq!(judge(Some(4.188 + 1e-7)).first().and_then(|r| r.verdict), Some(Verdict::StoppedAboveTarget));
    }

    /// A run's verdict is its own rows against its group's reference: a run of the batch
    /// below `E*` moves neither the reference nor another run's verdict, and a run taking its
    /// own start (the unscaled Tutte map, E0 = 50) is measured from the common start's E0.
    #[test]
    fn a_verdict_does_not_depend_on_the_other_runs_of_the_batch() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let a = ran(dir, "a", &[10.0, 3.0, 2.000001], true, 1e-4);
        let low = ran(dir, "low", &[10.0, 4.0, 1.999], false, 1e-2);
        let own = ran(dir, "own", &[50.0, 4.0, 2.05], true, 1e-4);
        let mut alone = vec![a.clone()];
        judge_batch(dir, &mut alone, &group(2.0, 10.0, 1.0), &targets(), tol).unwrap();
        let mut all = vec![a, low, own];
        judge_batch(dir, &mut all, &group(2.0, 10.0, 1.0), &targets(), tol).unwrap();
        assert_eq!(alone[0].verdict, all[0].verdict);
        assert_eq!(alone[0].final_gap, all[0].final_gap);
        assert!(all.iter().all(|r| r.ref_energy == Some(2.0) && r.gap_scale == Some(1.0)));
        assert_eq!(all[1].verdict, Some(Verdict::Solved));
        assert!(all[1].final_gap.unwrap() < 0.0);
        // the own start: E0 = 10 of the group, span min(10 - 2, 2 - 1) = 1
        assert_eq!((all[2].start_energy, all[2].gap_scale), (Some(10.0), Some(1.0)));
        assert!((all[2].final_gap.unwrap() - 0.05).abs() < 1e-12);
    }

    /// A run that passed a target and rose above it again, or whose final map flips faces,
    /// is not solved; its iterations to that target are not counted.
    #[test]
    fn the_final_map_decides() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let mut flipped = ran(dir, "f", &[10.0, 2.0], true, 1e-4);
        flipped.flips = Some(3);
        let mut rows = vec![ran(dir, "up", &[10.0, 2.0, 2.5], false, 1.0), flipped];
        judge_batch(dir, &mut rows, &group(2.0, 10.0, 1.0), &targets(), tol).unwrap();
        assert_eq!(
            verdicts(&rows),
            [(Status::NotConverged, Verdict::Unfinished), (Status::NotConverged, Verdict::Flipped)]
        );
        assert!(rows.iter().all(|r| r.to_targets.iter().all(|t| t.iters.is_none())));
    }

    /// Without a reference (none could be computed) the group is judged against the batch's
    /// best final energy, marked `batch` and uncertified.
    #[test]
    fn without_a_reference_the_batch_s_best_uncertified() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let mut rows = vec![ran(dir, "a", &[10.0, 3.0, 2.5], true, 1e-4), ran(dir, "b", &[10.0, 2.5, 2.0], true, 1e-4)];
        let mut none = group(f64::NAN, 10.0, 1.0);
        (none[0].e_star, none[0].origin, none[0].certified) = (None, Origin::Unavailable, false);
        judge_batch(dir, &mut rows, &none, &targets(), tol).unwrap();
        assert!(rows.iter().all(|r| r.ref_energy == Some(2.0)
            && r.ref_source == Some(RefSource::Batch)
            && r.ref_certified == Some(false)));
        assert_eq!(verdicts(&rows)[1], (Status::Ok, Verdict::Solved));
    }

    /// Each energy is judged at its own targets (SARAP at 1e-3 alone); each end above the
    /// target reads as its verdict; each rule's event is timed as a target is.
    #[test]
    fn each_energy_at_its_own_targets_each_end_its_verdict() {
        let tmp = run_folder();
        let dir = tmp.path();
        let tol = |_: &str| Some(1e-3);
        let mut sarap = group(2.0, 10.0, -98.0);
        sarap[0].energy = "sarap".into();
        let references: Vec<GroupReference> = group(2.0, 10.0, -98.0).into_iter().chain(sarap).collect();
        let targets = Targets::new(vec![1e-3, 1e-6], [("sarap".to_string(), vec![1e-3])].into());
        // 2.005: within 1e-3 (2.008), not 1e-6
        let end = |r: SummaryRow, reason: StopReason| SummaryRow {
            stop_reason: Some(RunStop::Solver(reason)),
            converged: false,
            ..r
        };
        let mut rows = vec![
            ran_on(dir, "sarap", "a", &[10.0, 3.0, 2.005], false, 1.0),
            end(ran(dir, "stall", &[10.0, 3.0, 2.005], false, 1.0), StopReason::NoDecrease),
            end(ran(dir, "floor", &[10.0, 3.0, 2.005], false, 1.0), StopReason::GradientFloor),
            end(ran(dir, "broke", &[10.0, 3.0, 2.005], false, 1.0), StopReason::LineSearchFailed),
            end(ran(dir, "cap", &[10.0, 3.0, 2.005], false, 1.0), StopReason::MaxIterations),
            end(ran(dir, "time", &[10.0, 3.0, 2.005], false, 1.0), StopReason::Timeout),
            end(ran(dir, "rule", &[10.0, 3.0, 2.005], false, 1e-4), StopReason::SolverRule),
            end(ran(dir, "lowered", &[10.0, 3.0, 2.005], false, 1.0), StopReason::Target),
        ];
        rows[0].rule_grad_tol_iters = Some(1);
        judge_batch(dir, &mut rows, &references, &targets, tol).unwrap();
        let v: Vec<Verdict> = rows.iter().map(|r| r.verdict.unwrap()).collect();
        use Verdict::*;
        let ends =
            [Solved, Stalled, Stalled, BrokeDown, Unfinished, Unfinished, StoppedAboveTarget, StoppedAboveTarget];
        assert_eq!(v, ends);
        assert_eq!(rows[0].to_targets.iter().map(|t| t.tau).collect::<Vec<_>>(), [1e-3]);
        assert_eq!(rows[1].to_targets.iter().map(|t| t.tau).collect::<Vec<_>>(), [1e-3, 1e-6]);
        // the event at row 1: 0.5 s of setup and one iteration of 1 s
        assert_eq!((rows[0].rule_grad_tol_time_s, rows[1].rule_grad_tol_time_s), (Some(1.5), None));
    }
}
