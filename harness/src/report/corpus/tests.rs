use super::*;
use crate::plan::Task;

fn run(d: &str, s: &str, status: Status, it: usize, t: f64) -> SummaryRow {
    SummaryRow {
        dataset: d.into(),
        task: Task::Param,
        energy: "sd".into(),
        solver: s.into(),
        iterations: Some(it),
        time_s: Some(t),
        status,
        ..Default::default()
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

#[test]
fn profile_values_on_a_hand_made_summary() {
    // 3 datasets x 2 solvers; a solves d1 in 10, d2 in 20, fails d3; b takes 20, 10, 30.
    let rows = [
        run("d1", "a", Status::Ok, 10, 1.0),
        run("d1", "b", Status::Ok, 20, 4.0),
        run("d2", "a", Status::Ok, 20, 1.0),
        run("d2", "b", Status::Ok, 10, 3.0),
        run("d3", "a", Status::Failed, 0, 0.001),
        run("d3", "b", Status::Ok, 30, 2.0),
    ];
    let refs: Vec<&SummaryRow> = rows.iter().collect();
    let p = performance_profiles(&refs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS);
    assert_eq!(p.problems, ["d1", "d2", "d3"]);
    assert!(p.left_out.is_empty());
    let (a, b) = (&p.profiles[0], &p.profiles[1]);
    assert_eq!((a.solver.as_str(), b.solver.as_str()), ("a", "b"));
    assert_eq!(a.ratios[..2], [1.0, 2.0]);
    assert_eq!(a.ratios[2], f64::INFINITY, "a failure is never solved");
    assert_eq!(b.ratios, [1.0, 1.0, 2.0]);
    for (tau, ra, rb) in
        [(1.0, 1.0 / 3.0, 2.0 / 3.0), (1.5, 1.0 / 3.0, 2.0 / 3.0), (2.0, 2.0 / 3.0, 1.0), (1e9, 2.0 / 3.0, 1.0)]
    {
        assert!(close(a.fraction_within(tau), ra), "a at {tau}");
        assert!(close(b.fraction_within(tau), rb), "b at {tau}");
    }
    assert!(close(p.tau_max(), 2.5));
    // The step polyline in log2 tau: flat at 1/3 until tau = 2 (x = 1), then 2/3.
    let steps = a.steps(p.tau_max());
    let want = [(0.0, 1.0 / 3.0), (1.0, 1.0 / 3.0), (1.0, 2.0 / 3.0), (2.5f64.log2(), 2.0 / 3.0)];
    assert_eq!(steps.len(), want.len());
    for (s, w) in steps.iter().zip(want) {
        assert!(close(s.0, w.0) && close(s.1, w.1), "{steps:?}");
    }
    // Times: a's 0.001 s failure does not make it the best on d3; ratios 4 and 3 for b.
    let p = performance_profiles(&refs, |r| r.time_s, PROFILE_MIN_TIME);
    assert_eq!(p.profiles[0].ratios[..2], [1.0, 1.0]);
    assert_eq!(p.profiles[1].ratios, [1.0, 3.0, 4.0]);
    assert!(close(p.profiles[1].fraction_within(3.5), 2.0 / 3.0));
}

#[test]
fn data_profiles_count_the_problems_solved_within_each_budget() {
    let rows = [
        run("d1", "a", Status::Ok, 10, 1.0),
        run("d1", "b", Status::Ok, 10, 4.0),
        // b's unsolved run is fast and never counts.
        run("d2", "a", Status::Ok, 10, 2.0),
        run("d2", "b", Status::NotConverged, 10, 0.5),
        run("d3", "a", Status::Failed, 0, 0.001),
        run("d3", "b", Status::Ok, 10, 3.0),
        // b skipped on d4: not a common problem.
        run("d4", "a", Status::Ok, 10, 0.1),
        run("d4", "b", Status::Skipped, 0, 0.0),
    ];
    let refs: Vec<&SummaryRow> = rows.iter().collect();
    let p = data_profiles(&refs, |r| r.time_s, PROFILE_MIN_TIME);
    assert_eq!(
        (p.problems.clone(), p.left_out.clone()),
        (vec!["d1".into(), "d2".into(), "d3".into()], vec!["d4".into()])
    );
    let (a, b) = (&p.profiles[0], &p.profiles[1]);
    assert_eq!(a.costs, [1.0, 2.0, f64::INFINITY]);
    assert_eq!(b.costs, [3.0, 4.0, f64::INFINITY]);
    for (alpha, da, db) in [
        (0.5, 0.0, 0.0),
        (1.0, 1.0 / 3.0, 0.0),
        (2.0, 2.0 / 3.0, 0.0),
        (3.0, 2.0 / 3.0, 1.0 / 3.0),
        (4.0, 2.0 / 3.0, 2.0 / 3.0),
        (1e9, 2.0 / 3.0, 2.0 / 3.0),
    ] {
        assert!(close(a.fraction_within(alpha), da), "a at {alpha}");
        assert!(close(b.fraction_within(alpha), db), "b at {alpha}");
    }
    // Half the cheapest solve to twice the dearest, at least a decade.
    assert_eq!(p.budget_range(), Some((0.5, 10.0)));
    let steps = a.steps(0.5, 10.0);
    let want = [
        (0.5f64.log10(), 0.0),
        (0.0, 0.0),
        (0.0, 1.0 / 3.0),
        (2f64.log10(), 1.0 / 3.0),
        (2f64.log10(), 2.0 / 3.0),
        (1.0, 2.0 / 3.0),
    ];
    assert_eq!(steps.len(), want.len(), "{steps:?}");
    for (s, w) in steps.iter().zip(want) {
        assert!(close(s.0, w.0) && close(s.1, w.1), "{steps:?}");
    }
    // Nothing solved: no axis.
    let none = data_profiles(&refs[4..5], |r| r.time_s, PROFILE_MIN_TIME);
    assert_eq!(none.budget_range(), None);
}

#[test]
fn profiles_use_a_common_problem_set_without_skipped_pairs() {
    let rows = [
        run("d1", "a", Status::Ok, 10, 1.0),
        run("d1", "b", Status::NotConverged, 1000, 9.0),
        run("d1", "c", Status::Skipped, 0, 0.0),
        // b skipped on d2: d2 leaves the problem set for everyone.
        run("d2", "a", Status::Ok, 10, 1.0),
        run("d2", "b", Status::Skipped, 0, 0.0),
        // nobody solves d3: it stays, unsolved for both.
        run("d3", "a", Status::NotConverged, 1000, 1.0),
        run("d3", "b", Status::Failed, 0, 0.0),
        // a converged at its initial map: floored at one iteration.
        run("d4", "a", Status::Ok, 0, 1.0),
        run("d4", "b", Status::Ok, 3, 1.0),
    ];
    let refs: Vec<&SummaryRow> = rows.iter().collect();
    let p = performance_profiles(&refs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS);
    let names: Vec<&str> = p.profiles.iter().map(|x| x.solver.as_str()).collect();
    assert_eq!(names, ["a", "b"], "c was skipped everywhere: not profiled");
    assert_eq!(p.problems, ["d1", "d3", "d4"]);
    assert_eq!(p.left_out, ["d2"]);
    assert_eq!(p.profiles[0].ratios, [1.0, 1.0, f64::INFINITY]);
    assert_eq!(p.profiles[1].ratios, [3.0, f64::INFINITY, f64::INFINITY]);
    assert!(close(p.profiles[1].fraction_within(2.9), 0.0));
    assert!(close(p.profiles[1].fraction_within(3.0), 1.0 / 3.0));
}

#[test]
fn shifted_geometric_means_count_unsolved_runs_at_the_cap_and_leave_skipped_out() {
    let mut rows = vec![
        run("d1", "a", Status::Ok, 10, 1.0),
        run("d2", "a", Status::Ok, 30, 3.0),
        run("d1", "b", Status::Ok, 20, 2.0),
        // Fails fast: enters at the caps, not at its 3 iterations and 0.01 s.
        run("d2", "b", Status::NotConverged, 3, 0.01),
        run("d1", "c", Status::Skipped, 0, 0.0),
        run("d2", "c", Status::Failed, 0, 0.0),
    ];
    rows[5].time_s = None;
    rows[5].iterations = None;
    rows[2].shifted_iters = Some(4);
    let batch = Batch { max_iters: [("sd".to_string(), 100)].into(), ..Default::default() };
    let agg = aggregate(&rows, &batch, TimeUnit::Seconds);
    assert_eq!(agg.len(), 1);
    let e = &agg[0];
    assert_eq!((e.energy.as_str(), e.datasets), ("sd", 2));
    assert_eq!(e.iteration_cap, Some(Cap { value: 100.0, source: CapSource::Limit }));
    // No timeout: the longest time any run of the energy took.
    assert_eq!(e.time_cap, Some(Cap { value: 3.0, source: CapSource::Observed }));
    let (a, b, c) = (&e.solvers[0], &e.solvers[1], &e.solvers[2]);
    assert_eq!((a.runs, a.solved, a.skipped, a.shifted), (2, 2, 0, 0));
    assert!(close(a.sgm_iterations.unwrap(), (20.0f64 * 40.0).sqrt() - 10.0));
    assert!(close(a.sgm_time.unwrap().value, (1.1f64 * 3.1).sqrt() - 0.1));
    assert_eq!((b.runs, b.solved, b.not_converged, b.shifted), (2, 1, 1, 1));
    assert!(close(b.sgm_iterations.unwrap(), (30.0f64 * 110.0).sqrt() - 10.0));
    assert!(close(b.sgm_time.unwrap().value, (2.1f64 * 3.1).sqrt() - 0.1));
    // c: the skipped run is left out, the failed one counts at the caps.
    assert_eq!((c.runs, c.solved, c.failed, c.skipped), (1, 0, 1, 1));
    assert!(close(c.sgm_iterations.unwrap(), 100.0));
    assert!(close(c.sgm_time.unwrap().value, 3.0));
    // Without max_iters in meta.json: the most iterations seen; with a timeout: the timeout.
    let batch = Batch { timeout_s: Some(60.0), ..Default::default() };
    let e = &aggregate(&rows, &batch, TimeUnit::Seconds)[0];
    assert_eq!(e.iteration_cap, Some(Cap { value: 30.0, source: CapSource::Observed }));
    assert_eq!(e.time_cap, Some(Cap { value: 60.0, source: CapSource::Limit }));
    assert!(close(e.solvers[2].sgm_time.unwrap().value, 60.0));
}

#[test]
fn time_spreads_and_units() {
    let mut rows = vec![run("d1", "a", Status::Ok, 10, 1.0), run("d2", "a", Status::Ok, 10, 4.0)];
    for r in &mut rows {
        (r.repeats, r.time_s_min, r.time_s_max) = (Some(5), r.time_s.map(|t| t * 0.5), r.time_s.map(|t| t * 2.0));
    }
    assert_eq!(TimeUnit::choose(&rows), TimeUnit::Seconds, "no time_norm");
    let t = aggregate(&rows, &Batch::default(), TimeUnit::Seconds)[0].solvers[0].sgm_time.unwrap();
    assert!(close(t.value, (1.1f64 * 4.1).sqrt() - 0.1));
    assert!(close(t.lo, (0.6f64 * 2.1).sqrt() - 0.1) && close(t.hi, (2.1f64 * 8.1).sqrt() - 0.1));
    assert_eq!(t.samples, 5);
    rows[0].time_norm = Some(2.0);
    assert_eq!(TimeUnit::choose(&rows), TimeUnit::Seconds, "one run without time_norm");
    rows[1].time_norm = Some(8.0);
    // A failed run without times does not stop normalization.
    rows.push(SummaryRow { status: Status::Failed, ..run("d3", "a", Status::Failed, 0, 0.0) });
    assert_eq!(TimeUnit::choose(&rows), TimeUnit::Calibrated);
    let t = TimeUnit::Calibrated.timed(&rows[0]).unwrap();
    assert!(close(t.lo, 1.0) && close(t.hi, 4.0), "the spread scales with the unit");
    let batch = Batch {
        calibration: Some(crate::calibration::Calibration { workload: "w".into(), samples_s: vec![0.5] }),
        timeout_s: Some(10.0),
        ..Default::default()
    };
    assert_eq!(TimeUnit::Calibrated.from_seconds(10.0, &batch), Some(20.0));
    assert_eq!(time_cap(&rows.iter().collect::<Vec<_>>(), &batch, TimeUnit::Calibrated).unwrap().value, 20.0);
    assert_eq!(TimeUnit::Calibrated.from_seconds(10.0, &Batch::default()), None);
}

/// A problem solved at its start (the common start within round-off of `E*`) ranks nothing:
/// the profiles and the aggregates leave its runs out, as they leave out skipped pairs.
#[test]
fn a_problem_solved_at_its_start_is_left_out_of_profiles_and_aggregates() {
    let at = |d: &str, s: &str, it: usize, e0: f64| SummaryRow {
        start_energy: Some(e0),
        ref_energy: Some(2.0),
        ..run(d, s, Status::Ok, it, it as f64)
    };
    let rows = [at("d1", "a", 10, 5.0), at("d1", "b", 20, 5.0), at("flat", "a", 0, 2.0), at("flat", "b", 0, 2.0)];
    let refs: Vec<&SummaryRow> = rows.iter().collect();
    let p = performance_profiles(&refs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS);
    assert_eq!(p.problems, ["d1"]);
    let agg = aggregate(&rows, &Batch::default(), TimeUnit::Seconds);
    assert_eq!((agg[0].datasets, agg[0].solvers[0].runs, agg[0].solvers[0].solved), (1, 1, 1));
}
