//! What an external solver's records come to: its clock checked against ours, the recording
//! time it may leave out, and its rows and outcome with our numbers at every verified map.

use super::protocol::{self, quoted, Record, Snapshot};
use crate::column_names::{intern, is_column_name};
use crate::run_folder::ITERATION_COLUMNS;
use solvers::solver::{Events, IterationRecord, Outcome, RowState, Stall, StopReason, StopSettings};
use std::path::Path;

/// The extra column that says which rows the harness recomputed (1) and which it took from the
/// solver's record (0).
pub const VERIFIED_COLUMN: &str = "verified";

/// The record key whose value is the time the solver spent on the record and its snapshot
/// (left out of the run's time like our solvers' `t_record_s`), not an extra column.
pub const RECORD_TIME_KEY: &str = "record_s";

/// The extra column with the energy the solver recorded at each row (the `energy` column is
/// ours, at the verified rows only).
pub const REPORTED_ENERGY_COLUMN: &str = "reported_energy";

/// What a solver may leave out of its time as recording, over the run: this many times what
/// the harness takes here to write the same files (each record line, and each map it wrote;
/// measured on the run's problem folder). An interpreter formats numbers some 10 to 20 times
/// slower than we do; the sum over the run absorbs a write a busy machine delayed.
pub const RECORD_FACTOR: f64 = 50.0;

/// ... and at least this much per row.
pub const RECORD_FLOOR_S: f64 = 0.005;

/// Slack of the solver's clock against the wall time the sandbox measured (two clocks, read
/// at slightly different moments), on top of 0.1 % of it.
const CLOCK_SLACK_S: f64 = 0.002;

/// What writing a record costs here, measured on the problem folder `dir`: a line appended
/// and flushed, and the map `x` formatted, written and renamed as the protocol asks (the
/// fastest of three of each).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RecordCost {
    pub(super) line_s: f64,
    pub(super) map_s: f64,
}

pub(super) fn record_cost(dir: &Path, x: &[f64]) -> RecordCost {
    use std::io::Write as _;
    let probe = dir.join(".record-cost");
    let (mut line_s, mut map_s) = (f64::INFINITY, f64::INFINITY);
    let uv: Vec<[f64; 2]> = x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let written = std::fs::File::create(&probe).and_then(|mut f| {
            f.write_all(
                b"{\"iter\": 1, \"energy\": 2.0000000000000004, \"time_s\": 0.0123456789, \"record_s\": 0.001}\n",
            )?;
            f.flush()
        });
        line_s = line_s.min(if written.is_ok() { t.elapsed().as_secs_f64() } else { 0.0 });
        let t = std::time::Instant::now();
        let tmp = dir.join(".record-cost.tmp");
        let written =
            std::fs::write(&tmp, crate::run_folder::map::uv_text(&uv)).and_then(|()| std::fs::rename(&tmp, &probe));
        map_s = map_s.min(if written.is_ok() { t.elapsed().as_secs_f64() } else { 0.0 });
    }
    let _ = std::fs::remove_file(&probe);
    RecordCost { line_s, map_s }
}

/// The solver's clock against the wall time `wall_s` of its process: no time past it, and its
/// times plus the recording it said it left out no more than it.
pub(super) fn check_clock(records: &[Record], wall_s: f64) -> Result<(), String> {
    let within = wall_s * 1.001 + CLOCK_SLACK_S;
    let mut recorded = 0.0;
    for r in records {
        if r.time_s > within {
            return Err(format!(
                "iteration {}: time_s = {} is past the {wall_s:.3} s its process ran (the harness's clock)",
                r.iter, r.time_s
            ));
        }
        match number(r, RECORD_TIME_KEY)? {
            Some(t) if !(t.is_finite() && t >= 0.0) => {
                return Err(format!("iteration {}: record_s = {t} is not a time (finite, at least 0)", r.iter))
            }
            Some(t) => recorded += t,
            None => {}
        }
    }
    let last = records.last().map_or(0.0, |r| r.time_s);
    if last + recorded > within {
        return Err(format!(
            "its clock does not add up: time_s = {last} at the last record plus {recorded} s of record_s is more \
             than the {wall_s:.3} s its process ran (record_s is the writing since the previous line, not a total)"
        ));
    }
    Ok(())
}

/// What an external run's records and verified snapshots make of its rows and outcome.
pub(super) struct Read {
    pub(super) outcome: Outcome,
    pub(super) rows: Vec<IterationRecord>,
    pub(super) verified: usize,
}

/// The run's rows: at a verified iteration its energy, gradient norm and flips are ours,
/// elsewhere its energy is the one recorded (gradient norm NaN, flips 0, `verified` 0); the
/// times are the solver's clock; its numeric extras become columns.
pub(super) fn rows_and_outcome(
    records: &[Record],
    snapshots: Vec<Snapshot>,
    stop: StopReason,
    rules: &StopSettings,
    cost: &RecordCost,
) -> Result<Read, String> {
    let names = extra_names(records)?;
    check_stationary(&stop, records, &snapshots[snapshots.len() - 1], rules)?;
    // Row k's record_s is the writing since row k - 1: its line, and its map if any. What is
    // left out over the run is bounded; past the bound every row's share is scaled down.
    let allowed: f64 = (1..records.len())
        .map(|k| {
            let map = if snapshots.iter().any(|s| s.iter == k - 1) { cost.map_s } else { 0.0 };
            (RECORD_FACTOR * (cost.line_s + map)).max(RECORD_FLOOR_S)
        })
        .sum();
    let mut reported = Vec::with_capacity(records.len());
    for r in records {
        reported.push(number(r, RECORD_TIME_KEY)?.unwrap_or(0.0).max(0.0));
    }
    let total: f64 = reported.iter().sum();
    let share = if total > allowed { allowed / total } else { 1.0 };
    let mut rows = Vec::with_capacity(records.len());
    let mut snaps = snapshots.iter().peekable();
    for (k, r) in records.iter().enumerate() {
        let snap = snaps.next_if(|s| s.iter == k);
        let mut extra =
            vec![(VERIFIED_COLUMN, if snap.is_some() { 1.0 } else { 0.0 }), (REPORTED_ENERGY_COLUMN, r.energy)];
        for &name in &names[OURS.len()..] {
            extra.push((name, number(r, name)?.unwrap_or(f64::NAN)));
        }
        let since = |t: f64| (t - records[0].time_s).max(0.0);
        rows.push(IterationRecord {
            iter: k,
            // Only our energies are judged (the convergence test, iterations and time to a
            // target): a row without a verified map has none.
            energy: snap.map_or(f64::NAN, |s| s.energy),
            grad_norm: snap.and_then(|s| s.grad_norm).unwrap_or(f64::NAN),
            step: f64::NAN,
            flips: snap.map_or(0, |s| s.flips),
            t_iter_s: if k == 0 { 0.0 } else { (r.time_s - records[k - 1].time_s).max(0.0) },
            t_cum_s: since(r.time_s),
            t_record_s: if k == 0 { 0.0 } else { reported[k] * share },
            extra,
            ..Default::default()
        });
    }
    let (first, last) = (&snapshots[0], &snapshots[snapshots.len() - 1]);
    let outcome = Outcome {
        x: last.x.clone(),
        iterations: last.iter,
        stop_reason: stop,
        init_energy: first.energy,
        final_energy: last.energy,
        grad_norm: last.grad_norm.unwrap_or(f64::NAN),
        flips: last.flips,
        analysis: None,
        start: None,
        events: events(records, &rows, rules),
    };
    Ok(Read { outcome, rows, verified: snapshots.len() })
}

/// A solver that says it ended stationary must be: `no_decrease` where its recorded energies'
/// lowest fell by no more than round-off over the problem's `stall_window`, as ours stall;
/// `grad_floor` where the gradient we computed on its final map is within the floor.
fn check_stationary(
    stop: &StopReason,
    records: &[Record],
    last: &Snapshot,
    rules: &StopSettings,
) -> Result<(), String> {
    match stop {
        StopReason::NoDecrease => {
            let mut stall = Stall::new(rules.stall_window);
            let stalled = records.iter().fold(false, |_, r| stall.push(r.energy));
            if stalled {
                return Ok(());
            }
            let w = rules.stall_window;
            let lowest = |rs: &[Record]| rs.iter().map(|r| r.energy).fold(f64::INFINITY, f64::min);
            let fell = match records.len().checked_sub(w) {
                Some(k) if w > 0 && k > 0 => lowest(&records[..k]) - lowest(records),
                _ => f64::NAN,
            };
            Err(if w == 0 {
                "says no_decrease, but the problem has no stall window".to_string()
            } else if fell.is_nan() {
                format!("says no_decrease after {} iterations, fewer than the stall window of {w}", records.len() - 1)
            } else {
                format!("says no_decrease, but its lowest energy fell by {fell:.2e} over the last {w} iterations")
            })
        }
        StopReason::GradientFloor => match last.grad_norm {
            Some(g) if rules.grad_floor > 0.0 && g <= rules.grad_floor => Ok(()),
            g => Err(format!(
                "says grad_floor, but the gradient norm of its final map (iteration {}) is {} (the floor: {:e})",
                last.iter,
                g.map_or("not finite".into(), |g| format!("{g:e}")),
                rules.grad_floor
            )),
        },
        _ => Ok(()),
    }
}

/// Where the problem's rules first held in an external run, as ours mark them: the gradient's
/// on the norms we computed (verified rows only), the decrease's on the energies it recorded.
fn events(records: &[Record], rows: &[IterationRecord], rules: &StopSettings) -> Events {
    let mut events = Events::default();
    for (k, row) in rows.iter().enumerate() {
        let decrease = if k == 0 { f64::INFINITY } else { records[k - 1].energy - records[k].energy };
        let at =
            RowState { grad_norm: row.grad_norm, last_decrease: decrease, iter: k, at_target: false, stalled: false };
        rules.mark(&at, &mut events);
    }
    events
}

/// Our columns of an external run's rows, before its own.
const OURS: [&str; 2] = [VERIFIED_COLUMN, REPORTED_ENERGY_COLUMN];

/// The columns of an external run's rows: ours, then the numeric extras its records name (in
/// order of appearance); a name of ours or that is no column, or too many, is an error.
fn extra_names(records: &[Record]) -> Result<Vec<&'static str>, String> {
    let mut names: Vec<&'static str> = OURS.to_vec();
    for r in records {
        for key in r.extras.keys().filter(|k| k.as_str() != RECORD_TIME_KEY) {
            if !is_column_name(key) || ITERATION_COLUMNS.contains(&key.as_str()) || OURS.contains(&key.as_str()) {
                return Err(format!(
                    "iteration {}: `{}` cannot be an extra column (plain names, not ours)",
                    r.iter,
                    quoted(key)
                ));
            }
            if !names.contains(&key.as_str()) {
                if names.len() - OURS.len() >= protocol::EXTRA_COLUMNS_MAX {
                    return Err(format!(
                        "more than {} extra columns (at iteration {}: `{}`)",
                        protocol::EXTRA_COLUMNS_MAX,
                        r.iter,
                        quoted(key)
                    ));
                }
                names.push(intern(key));
            }
        }
    }
    Ok(names)
}

/// A record's extra `name` as a number (`true`/`false` as 1/0, `null` as none).
fn number(r: &Record, name: &str) -> Result<Option<f64>, String> {
    match r.extras.get(name) {
        None | Some(serde_json::Value::Null) => Ok(None),
        Some(serde_json::Value::Bool(b)) => Ok(Some(if *b { 1.0 } else { 0.0 })),
        Some(serde_json::Value::Number(n)) => Ok(n.as_f64()),
        Some(other) => {
            Err(format!("iteration {}: extra `{name}` = {} is not a number", r.iter, quoted(&other.to_string())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(iter: usize, energy: f64, time_s: f64, extras: serde_json::Value) -> Record {
        let serde_json::Value::Object(map) = extras else { panic!() };
        Record { iter, energy, time_s, extras: map.into_iter().collect() }
    }

    fn snapshot(iter: usize, energy: f64) -> Snapshot {
        Snapshot { iter, energy, grad_norm: Some(0.5), flips: 1, x: vec![iter as f64; 4] }
    }

    /// Writing costs that allow 0.25 s after a map and 0.0125 s after a line alone.
    const COST: RecordCost = RecordCost { line_s: 0.0125 / RECORD_FACTOR, map_s: 0.2375 / RECORD_FACTOR };
    /// Writing that costs nothing here: the floor alone.
    const FREE: RecordCost = RecordCost { line_s: 0.0, map_s: 0.0 };
    /// The papers' gradient rule (our verified norms are 0.5) and a decrease rule.
    const RULES: StopSettings = StopSettings::rules_only(0.6, 0.3, 100);

    #[test]
    fn rows_take_our_numbers_where_verified_and_the_solvers_extras_as_columns() {
        let records = [
            record(0, 3.0, 0.5, serde_json::json!({})),
            record(1, 2.5, 1.5, serde_json::json!({"decrease": 0.2, "record_s": 0.75})),
            record(2, 2.25, 1.75, serde_json::json!({"accepted": true, "record_s": 0.125})),
        ];
        let snaps = vec![snapshot(0, 3.0 + 1e-12), snapshot(2, 2.25)];
        let read = rows_and_outcome(&records, snaps.clone(), StopReason::SolverRule, &RULES, &COST).unwrap();
        let r = &read.rows;
        // the energy of a row without its map is not ours: left out of every judgement
        assert_eq!(r[0].energy, 3.0 + 1e-12);
        assert!(r[1].energy.is_nan() && r[1].grad_norm.is_nan() && r[1].step.is_nan());
        assert_eq!(r[2].energy, 2.25);
        assert_eq!((r[0].grad_norm, r[0].flips, r[1].flips), (0.5, 1, 0));
        // record_s over the run (0.875 s) past what writing row 0's line and map and row 1's
        // line cost here (0.2625 s): each row's share scaled down to it
        assert_eq!(
            r.iter().map(|r| (r.t_iter_s, r.t_cum_s)).collect::<Vec<_>>(),
            [(0.0, 0.0), (1.0, 1.0), (0.25, 1.25)]
        );
        let near = |got: &[f64], want: [f64; 3]| got.iter().zip(want).all(|(g, w)| (g - w).abs() <= 1e-15);
        let kept: Vec<f64> = r.iter().map(|r| r.t_record_s).collect();
        assert!(near(&kept, [0.0, 0.75 * 0.3, 0.125 * 0.3]), "{kept:?}");
        // writing that costs nothing here still leaves 5 ms a row
        let free = rows_and_outcome(&records, snaps, StopReason::SolverRule, &RULES, &FREE).unwrap();
        let kept: Vec<f64> = free.rows.iter().map(|r| r.t_record_s).collect();
        assert!(near(&kept, [0.0, 0.75 * 0.01 / 0.875, 0.125 * 0.01 / 0.875]), "{kept:?}");
        // within the bound, as reported
        let cheap =
            [record(0, 3.0, 0.5, serde_json::json!({})), record(1, 2.5, 1.5, serde_json::json!({"record_s": 0.2}))];
        let within =
            rows_and_outcome(&cheap, vec![snapshot(0, 3.0), snapshot(1, 2.5)], StopReason::SolverRule, &RULES, &COST);
        assert_eq!(within.unwrap().rows[1].t_record_s, 0.2);
        let names: Vec<&str> = r[1].extra.iter().map(|e| e.0).collect();
        assert_eq!(names, [VERIFIED_COLUMN, REPORTED_ENERGY_COLUMN, "decrease", "accepted"]);
        assert_eq!((r[1].extra[0].1, r[1].extra[1].1), (0.0, 2.5));
        assert_eq!((r[2].extra[0].1, r[2].extra[3].1), (1.0, 1.0));
        assert!(r[0].extra[2].1.is_nan() && r[2].extra[2].1.is_nan());
        let o = &read.outcome;
        assert_eq!((o.iterations, o.init_energy, o.final_energy, o.flips, read.verified), (2, 3.0 + 1e-12, 2.25, 1, 2));
        assert_eq!((o.x.clone(), o.stop_reason.clone()), (vec![2.0; 4], StopReason::SolverRule));
        // the gradient rule on our norms (row 1 has none: unverified), the decrease on the
        // energies it recorded (0.5, then 0.25 < 0.3)
        assert_eq!((o.events.grad_tol, o.events.energy_decrease), (Some(0), Some(2)));

        // a name of ours, a name that is no column, a value that is no number
        for (extras, says) in [
            (serde_json::json!({"grad_norm": 1.0}), "`grad_norm` cannot be an extra column"),
            (serde_json::json!({"reported_energy": 1.0}), "`reported_energy` cannot be an extra column"),
            (serde_json::json!({"a b": 1.0}), "`a b` cannot be an extra column"),
            (serde_json::json!({"note": "x"}), "extra `note` = \"x\" is not a number"),
        ] {
            let bad = [record(0, 3.0, 0.0, extras)];
            let err =
                rows_and_outcome(&bad, vec![snapshot(0, 3.0)], StopReason::MaxIterations, &RULES, &COST).err().unwrap();
            assert!(err.contains(says), "{err}");
        }
        // more names than a record may have, over the records
        let wide: Vec<Record> = (0..=protocol::EXTRA_COLUMNS_MAX)
            .map(|k| record(k, 3.0, k as f64, serde_json::json!({ format!("c{k}"): 1 })))
            .collect();
        let err =
            rows_and_outcome(&wide, vec![snapshot(0, 3.0)], StopReason::MaxIterations, &RULES, &COST).err().unwrap();
        assert_eq!(err, "more than 32 extra columns (at iteration 32: `c32`)");
    }

    #[test]
    fn a_stationary_end_holds_on_the_records_or_fails_the_run() {
        let stop = StopSettings { stall_window: 3, grad_floor: 1e-8, ..RULES };
        let run = |energies: &[f64]| -> Vec<Record> {
            energies.iter().enumerate().map(|(k, &e)| record(k, e, k as f64, serde_json::json!({}))).collect()
        };
        let last = |grad: Option<f64>| Snapshot { grad_norm: grad, ..snapshot(5, 2.0) };
        let says = |reason: StopReason, energies: &[f64], grad: Option<f64>, rules: &StopSettings| {
            check_stationary(&reason, &run(energies), &last(grad), rules)
        };
        // the lowest energy of the last 3 iterations is the one 3 before, up to round-off
        // (an iteration that rises does not count against it)
        let flat = [3.0, 2.0, 2.0 + 1e-15, 2.0 - 1e-13, 2.0];
        assert_eq!(says(StopReason::NoDecrease, &flat, None, &stop), Ok(()));
        let falling = [3.0, 2.5, 2.2, 2.1, 2.05];
        let err = says(StopReason::NoDecrease, &falling, None, &stop).unwrap_err();
        assert_eq!(err, "says no_decrease, but its lowest energy fell by 4.50e-1 over the last 3 iterations");
        let err = says(StopReason::NoDecrease, &flat[..3], None, &stop).unwrap_err();
        assert_eq!(err, "says no_decrease after 2 iterations, fewer than the stall window of 3");
        let err = says(StopReason::NoDecrease, &flat, None, &RULES).unwrap_err();
        assert_eq!(err, "says no_decrease, but the problem has no stall window");
        // the floor on the gradient we computed at the final map
        assert_eq!(says(StopReason::GradientFloor, &falling, Some(1e-9), &stop), Ok(()));
        let err = says(StopReason::GradientFloor, &falling, Some(1e-6), &stop).unwrap_err();
        assert_eq!(
            err,
            "says grad_floor, but the gradient norm of its final map (iteration 5) is 1e-6 (the floor: 1e-8)"
        );
        assert!(says(StopReason::GradientFloor, &falling, None, &stop).unwrap_err().contains("is not finite"));
        assert!(says(StopReason::GradientFloor, &falling, Some(0.0), &RULES).is_err());
        // any other end is the solver's word
        assert_eq!(says(StopReason::MaxIterations, &falling, None, &RULES), Ok(()));
        // and the run fails with it
        let err = rows_and_outcome(
            &run(&falling),
            vec![snapshot(0, 3.0), snapshot(4, 2.05)],
            StopReason::NoDecrease,
            &stop,
            &COST,
        )
        .err()
        .unwrap();
        assert!(err.starts_with("says no_decrease"), "{err}");
    }

    #[test]
    fn a_clock_past_the_wall_time_or_that_does_not_add_up_fails() {
        let at = |t: &[(f64, Option<f64>)]| -> Vec<Record> {
            t.iter()
                .enumerate()
                .map(|(k, &(time_s, rec))| {
                    record(k, 3.0, time_s, rec.map_or(serde_json::json!({}), |r| serde_json::json!({"record_s": r})))
                })
                .collect()
        };
        assert_eq!(check_clock(&at(&[(0.1, None), (0.5, Some(0.2)), (0.9, Some(0.05))]), 1.2), Ok(()));
        let err = check_clock(&at(&[(0.1, None), (1e9, None)]), 1.2).unwrap_err();
        assert_eq!(err, "iteration 1: time_s = 1000000000 is past the 1.200 s its process ran (the harness's clock)");
        // record_s reported as a running total
        let err = check_clock(&at(&[(0.1, None), (0.4, Some(0.3)), (0.7, Some(0.6))]), 1.2).unwrap_err();
        assert!(err.starts_with("its clock does not add up: time_s = 0.7 at the last record plus 0.899"), "{err}");
        let err = check_clock(&at(&[(0.1, None), (0.4, Some(-0.3))]), 1.2).unwrap_err();
        assert_eq!(err, "iteration 1: record_s = -0.3 is not a time (finite, at least 0)");
    }
}
