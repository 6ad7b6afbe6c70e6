//! The regression gate: a JSON baseline of iteration counts and final energies per run, and
//! the comparison of a run folder against it (`baseline`, `check`), by the rules of
//! [`super::rules`].

use super::rules;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use super::rules::{Change, GatedRun, DEFAULT_ENERGY_RTOL};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baseline {
    /// Relative tolerance on `final_energy`.
    #[serde(default = "default_rtol")]
    pub energy_rtol: f64,
    pub runs: Vec<GatedRun>,
}

impl Baseline {
    /// Read and check a baseline file.
    pub fn load(path: &Path) -> Result<Baseline> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("{}: cannot read baseline", path.display()))?;
        Self::parse(&text, path)
    }

    /// A baseline from its JSON text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Baseline> {
        let base: Baseline =
            serde_json::from_str(text).with_context(|| format!("{}: invalid baseline", path.display()))?;
        base.check().with_context(|| format!("{}: invalid baseline", path.display()))?;
        Ok(base)
    }

    /// What serde cannot check: a tolerance that makes sense, at least one run (an empty
    /// baseline would pass every batch), and each run once (two records of one run could
    /// disagree, and the gate would pick one silently).
    pub fn check(&self) -> Result<()> {
        rules::check_energy_rtol(self.energy_rtol)?;
        if self.runs.is_empty() {
            bail!("'runs' is empty: a baseline with no run would pass every batch");
        }
        let mut seen = std::collections::HashSet::new();
        for (i, r) in self.runs.iter().enumerate() {
            if !seen.insert(r.key()) {
                bail!("run {i} ({}) appears twice", r.label());
            }
        }
        Ok(())
    }
}

fn default_rtol() -> f64 {
    DEFAULT_ENERGY_RTOL
}

/// Read the records of a run folder's `summary.csv`.
pub fn read_summary(run_dir: &Path) -> Result<Vec<GatedRun>> {
    Ok(crate::run_folder::read_summary(run_dir)?.iter().map(GatedRun::from).collect())
}

/// A baseline from a run folder.
pub fn make_baseline(run_dir: &Path) -> Result<Baseline> {
    let base = Baseline { energy_rtol: DEFAULT_ENERGY_RTOL, runs: read_summary(run_dir)? };
    base.check().with_context(|| format!("{}: no baseline can be made", run_dir.display()))?;
    Ok(base)
}

/// The outcome of a comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    pub changes: Vec<Change>,
    pub missing: Vec<String>,
    pub compared: usize,
    /// Advisory wall-time lines (baseline vs now) for the runs compared.
    pub timings: Vec<(String, f64, f64)>,
}

impl Comparison {
    pub fn regressions(&self) -> usize {
        self.changes.iter().filter(|c| c.regression).count()
    }
    pub fn improvements(&self) -> usize {
        self.changes.iter().filter(|c| !c.regression).count()
    }
    /// 2 when a baseline run is missing, 1 on any regression, else 0.
    pub fn exit_code(&self) -> u8 {
        if !self.missing.is_empty() {
            2
        } else if self.regressions() > 0 {
            1
        } else {
            0
        }
    }
}

/// Compare the runs of a folder with a baseline.
pub fn compare(baseline: &Baseline, runs: &[GatedRun]) -> Comparison {
    let mut cmp = Comparison::default();
    for b in &baseline.runs {
        let Some(a) = runs.iter().find(|r| r.key() == b.key()) else {
            cmp.missing.push(b.label());
            continue;
        };
        cmp.compared += 1;
        cmp.changes.extend(rules::changes(b, a, baseline.energy_rtol));
        if let (Some(bt), Some(at)) = (b.time_s, a.time_s) {
            cmp.timings.push((b.label(), bt, at));
        }
    }
    cmp
}

/// A human-readable report of a comparison.
pub fn render(cmp: &Comparison) -> String {
    let mut s = String::new();
    let table = |rows: Vec<&Change>, title: &str| {
        let mut t =
            format!("{title}:\n  {:<48} {:<13} {:>16} {:>16} {:>12}\n", "run", "metric", "before", "after", "delta");
        for c in rows {
            t += &format!("  {:<48} {:<13} {:>16} {:>16} {:>12}\n", c.run, c.metric, c.before, c.after, c.delta);
        }
        t
    };
    let regs: Vec<&Change> = cmp.changes.iter().filter(|c| c.regression).collect();
    let imps: Vec<&Change> = cmp.changes.iter().filter(|c| !c.regression).collect();
    if !regs.is_empty() {
        s += &table(regs, "REGRESSIONS");
    }
    if !imps.is_empty() {
        s += &table(
            imps,
            "Improvements (not a failure; refresh the baseline with `mapbench baseline RUN_DIR --write FILE`)",
        );
    }
    if !cmp.missing.is_empty() {
        s += &format!("MISSING from the run folder ({}):\n", cmp.missing.len());
        for m in &cmp.missing {
            s += &format!("  {m}\n");
        }
    }
    if !cmp.timings.is_empty() {
        let (bt, at): (f64, f64) = cmp.timings.iter().fold((0.0, 0.0), |(x, y), (_, b, a)| (x + b, y + a));
        s += &format!(
            "timings (advisory, not gated): total {bt:.2} s in the baseline, {at:.2} s now ({:.2}x)\n",
            at / bt.max(1e-12)
        );
    }
    s += &format!(
        "{} runs compared: {} regressions, {} improvements, {} missing\n",
        cmp.compared,
        cmp.regressions(),
        cmp.improvements(),
        cmp.missing.len()
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gate::rules::tests::record as rec;
    use crate::run_folder::Status;

    fn base(runs: Vec<GatedRun>) -> Baseline {
        Baseline { energy_rtol: 1e-6, runs }
    }

    #[test]
    fn identical_runs_pass() {
        let runs = vec![rec("a", 10, 2.0), rec("b", 20, 2.0)];
        let c = compare(&base(runs.clone()), &runs);
        assert_eq!((c.exit_code(), c.compared, c.changes.len()), (0, 2, 0));
    }

    #[test]
    fn more_iterations_fail_fewer_are_reported() {
        let b = base(vec![rec("a", 10, 2.0), rec("b", 20, 2.0)]);
        let c = compare(&b, &[rec("a", 11, 2.0), rec("b", 18, 2.0)]);
        assert_eq!(c.exit_code(), 1);
        assert_eq!(c.regressions(), 1);
        assert_eq!(c.improvements(), 1);
        let text = render(&c);
        assert!(text.contains("REGRESSIONS") && text.contains("+1") && text.contains("-2") && text.contains("refresh"));
        // within a per-record tolerance it passes
        let mut tolerant = b.clone();
        tolerant.runs[0].iterations_tolerance = Some(2);
        assert_eq!(compare(&tolerant, &[rec("a", 12, 2.0), rec("b", 20, 2.0)]).exit_code(), 0);
    }

    #[test]
    fn energy_status_and_flips_are_gated() {
        let b = base(vec![rec("a", 10, 2.0)]);
        assert_eq!(compare(&b, &[rec("a", 10, 2.0 * (1.0 + 1e-7))]).exit_code(), 0);
        assert_eq!(compare(&b, &[rec("a", 10, 2.01)]).exit_code(), 1);
        assert_eq!(compare(&b, &[rec("a", 10, 1.99)]).exit_code(), 0); // lower energy: improvement
        let mut worse = rec("a", 10, 2.0);
        worse.status = Status::NotConverged;
        assert_eq!(compare(&b, &[worse]).exit_code(), 1);
        let mut flipped = rec("a", 10, 2.0);
        flipped.flips = Some(3);
        assert_eq!(compare(&b, &[flipped]).exit_code(), 1);
        let mut nan = rec("a", 10, 2.0);
        nan.final_energy = Some(f64::NAN);
        assert_eq!(compare(&b, &[nan]).exit_code(), 1);
    }

    /// Found by review of the baseline fuzz target: huge counts or tolerances in a baseline
    /// overflowed (a panic in debug builds, a wrong verdict in release).
    #[test]
    fn huge_iteration_counts_and_tolerances_compare() {
        let mut b = base(vec![rec("a", 3, 2.0)]);
        b.runs[0].iterations_tolerance = Some(usize::MAX);
        assert_eq!(compare(&b, &[rec("a", 5, 2.0)]).exit_code(), 0);
        let big = 1usize << 63;
        let c = compare(&base(vec![rec("a", big, 2.0)]), &[rec("a", 1, 2.0)]);
        assert_eq!((c.exit_code(), c.improvements()), (0, 1));
        assert_eq!(c.changes[0].delta, format!("-{}", big - 1));
    }

    /// A pair skipped in both the baseline and the run is no change; a run that becomes
    /// skipped (it stopped being run) is a regression, and one that stops being skipped an
    /// improvement.
    #[test]
    fn skipped_runs_compare_by_status_only() {
        let skipped = |solver: &str| GatedRun {
            iterations: None,
            final_energy: None,
            flips: None,
            status: Status::Skipped,
            time_s: None,
            ..rec(solver, 0, 0.0)
        };
        let c = compare(&base(vec![skipped("a")]), &[skipped("a")]);
        assert_eq!((c.exit_code(), c.compared, c.changes.len()), (0, 1, 0));
        for before in [Status::Ok, Status::NotConverged, Status::Failed] {
            let was = GatedRun { status: before, ..rec("a", 10, 2.0) };
            let c = compare(&base(vec![was]), &[skipped("a")]);
            assert_eq!(c.exit_code(), 1, "{before} -> skipped: {}", render(&c));
            let status = c.changes.iter().find(|ch| ch.metric == "status").unwrap();
            assert!(status.regression && status.after == "skipped", "{status:?}");
        }
        // skipped -> ok: the pair runs now
        let c = compare(&base(vec![skipped("a")]), &[rec("a", 10, 2.0)]);
        assert_eq!((c.exit_code(), c.regressions(), c.improvements()), (0, 0, 2), "{}", render(&c));
        // skipped -> failed is a failure like any other
        let failed = GatedRun { status: Status::Failed, ..skipped("a") };
        assert_eq!(compare(&base(vec![skipped("a")]), &[failed]).exit_code(), 1);
    }

    #[test]
    fn missing_runs_exit_2() {
        let b = base(vec![rec("a", 10, 2.0), rec("b", 20, 2.0)]);
        let c = compare(&b, &[rec("a", 10, 2.0)]);
        assert_eq!(c.exit_code(), 2);
        assert!(render(&c).contains("MISSING") && render(&c).contains("d param sd b"));
    }

    #[test]
    fn baselines_that_cannot_gate_are_refused_naming_the_file() {
        let p = Path::new("base.json");
        let err = |text: &str| format!("{:#}", Baseline::parse(text, p).unwrap_err());
        let one = serde_json::to_string(&rec("a", 10, 2.0)).unwrap();
        assert!(Baseline::parse(&format!(r#"{{"runs": [{one}]}}"#), p).is_ok());
        for (text, why) in [
            (format!(r#"{{"energy_rtol": -1, "runs": [{one}]}}"#), "energy_rtol = -1 must be non-negative"),
            (r#"{"runs": []}"#.to_string(), "'runs' is empty"),
            (format!(r#"{{"runs": [{one}, {one}]}}"#), "run 1 (d param sd a) appears twice"),
            ("{".to_string(), "invalid baseline"),
        ] {
            let e = err(&text);
            assert!(e.starts_with("base.json: invalid baseline") && e.contains(why), "{text}: {e}");
        }
        // A different record of the same run is a duplicate too.
        let other = serde_json::to_string(&rec("a", 11, 2.0)).unwrap();
        assert!(err(&format!(r#"{{"runs": [{one}, {other}]}}"#)).contains("appears twice"));
    }
}
