//! The end of each run and of the batch: the files of a run whose last repeat is in, the
//! repeats an interrupt cut short, the batch's totals and notices, its verdict and its summary.

use super::progress::Progress;
use super::record::BatchRecord;
use super::repeats::Slot;
use crate::calibration::Calibration;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::{sidecar, summary_csv, write_run, MapBytes, RunFiles, Status, SummaryRow, SummaryWriter};
use anyhow::Result;
use std::path::{Path, PathBuf};

/// Totals of a batch.
#[derive(Debug, Default, PartialEq)]
pub struct BatchReport {
    pub runs: usize,
    pub ok: usize,
    pub not_converged: usize,
    /// Runs of a fixed-budget protocol that spent it (`Status::Budget`).
    pub budget: usize,
    pub failed: usize,
    /// Pairs outside a solver's declared energies: not run.
    pub skipped: usize,
    /// Runs not done because the batch was interrupted.
    pub interrupted: usize,
    /// FinishedRun runs taken from an earlier batch in the folder (`--resume`).
    pub resumed: usize,
    /// Runs an interrupt cut short in their repeats, with how many repeats finished; kept in
    /// `runs/<run>.partial.*` for `--resume`, not in `summary.csv`.
    pub partial: Vec<(String, usize)>,
    /// The plan's notices (datasets skipped, externals declared but not named in `solvers`).
    pub notices: Vec<String>,
    pub out_dir: PathBuf,
    /// What became of the batch in the history database.
    pub history: crate::history::HistoryOutcome,
}

/// A finished run: its index in the batch, its row, whether it was resumed, and the key of
/// the sidecar this batch wrote.
pub(super) struct FinishedRun {
    index: usize,
    summary: SummaryRow,
    resumed: bool,
    wrote: Option<String>,
    /// Its map that ended below its group's reference.
    candidate: Option<crate::judge::improve::Candidate>,
}

/// The maps of the finished runs that ended below their group's reference.
pub(super) fn take_candidates(finished: &mut [FinishedRun]) -> Vec<crate::judge::improve::Candidate> {
    finished.iter_mut().filter_map(|f| f.candidate.take()).collect()
}

/// Writes each run's files as its last repeat comes in, and counts it.
pub(super) struct Finisher<'a> {
    pub out_dir: &'a Path,
    pub mine: &'a [&'a PlannedRun],
    pub progress: &'a dyn Progress,
    pub summary: SummaryWriter,
    pub finished: Vec<FinishedRun>,
    /// Datasets whose mesh copy this batch has written (once each, with its first map).
    pub meshes_written: Vec<usize>,
    pub report: BatchReport,
}

impl Finisher<'_> {
    /// Write run `i`'s files (its CSV, map, sidecar) and its summary row, and count it.
    pub fn finish(&mut self, i: usize, worker: usize, slot: Slot) -> Result<()> {
        let Slot { mut first, resumed, key, repeats } = slot;
        if let Some(r) = repeats {
            r.apply(&mut first);
        }
        let p = self.mine[i];
        // A run whose files cannot be written (a folder in the way, a name the OS refuses)
        // fails alone, like any other failed run; without a sidecar `--resume` retries it.
        let sidecar_key = key.as_deref().filter(|_| !resumed);
        let meshes_written = &self.meshes_written;
        let files = RunFiles {
            stem: &p.stem,
            summary: &first.summary,
            rows: &first.rows,
            map: first.map_uv.as_deref().map(|uv| MapBytes {
                dataset: &first.summary.dataset,
                uv,
                mesh: first.mesh_file.as_deref().filter(|_| !meshes_written.contains(&p.dataset)).map(|m| m.as_slice()),
            }),
            key: sidecar_key,
        };
        let written = write_run(self.out_dir, &files);
        if written.is_ok() && files.map.as_ref().is_some_and(|m| m.mesh.is_some()) {
            self.meshes_written.push(p.dataset);
        }
        let wrote = sidecar_key.filter(|_| written.is_ok()).map(str::to_string);
        if sidecar_key.is_none() && !resumed {
            // A previous batch's sidecar must not vouch for these files.
            let _ = std::fs::remove_file(sidecar::path(self.out_dir, &p.stem));
        }
        if let Err(e) = written {
            let s = &first.summary;
            first.summary = SummaryRow {
                dataset: s.dataset.clone(),
                task: s.task,
                energy: s.energy.clone(),
                solver: s.solver.clone(),
                vertices: s.vertices,
                faces: s.faces,
                status: Status::Failed,
                error: format!("{e:#}"),
                ..Default::default()
            };
        }
        let s = &first.summary;
        let line = run_line(self.finished.len() + 1, self.mine.len(), s, resumed);
        self.progress.run_finished(worker, &line);
        let report = &mut self.report;
        match s.status {
            Status::Ok => report.ok += 1,
            Status::NotConverged => report.not_converged += 1,
            Status::Budget => report.budget += 1,
            Status::Failed => report.failed += 1,
            Status::Skipped => report.skipped += 1,
        }
        report.runs += 1;
        report.resumed += usize::from(resumed);
        self.summary.append(s)?;
        let candidate = first.candidate.take();
        self.finished.push(FinishedRun { index: i, summary: first.summary, resumed, wrote, candidate });
        Ok(())
    }

    /// After the last round: the runs whose repeats are all in are finished; those an
    /// interrupt cut short keep their repeats so far for `--resume` (no summary row: they did
    /// not finish). A run whose repeats disagreed has its result (repeat 1's, flagged) whatever is
    /// missing.
    pub fn keep_partials(&mut self, slots: &mut [Option<Slot>], repeat: usize) -> Result<()> {
        for (i, slot) in slots.iter_mut().enumerate() {
            let Some(slot) = slot.take() else { continue };
            if slot.complete(repeat) {
                self.finish(i, 0, slot)?;
                continue;
            }
            let stem = &self.mine[i].stem;
            let Slot { first, key, repeats, .. } = slot;
            let Some(repeats) = repeats else { continue };
            // An earlier batch's sidecar must not vouch for this run.
            let _ = std::fs::remove_file(sidecar::path(self.out_dir, stem));
            self.report.partial.push((stem.clone(), repeats.count()));
            if let Some(key) = key {
                let partial = sidecar::Partial { key, summary: first.summary, repeats };
                if let Err(e) = sidecar::write_partial(self.out_dir, stem, &partial, &first.rows) {
                    self.progress.notice(&format!("{stem}: its repeats so far cannot be kept for --resume: {e:#}"));
                }
            }
        }
        Ok(())
    }
}

/// What a finished batch says besides its runs: what an interrupt left, and a machine that
/// changed speed.
pub(super) fn batch_notices(report: &BatchReport, repeat: usize, calibration: &Calibration, progress: &dyn Progress) {
    if report.interrupted > 0 {
        let partial = match report.partial.len() {
            0 => String::new(),
            n => format!(
                "{n} cut short in their repeats ({}; kept for `--resume`), ",
                report.partial.iter().map(|(s, k)| format!("{s} {k}/{repeat}")).collect::<Vec<_>>().join(", ")
            ),
        };
        progress.notice(&format!(
            "interrupted: {} runs finished and written, {partial}{} not run (`--resume` runs them)",
            report.runs,
            report.interrupted - report.partial.len()
        ));
    }
    if calibration.unsteady() {
        progress.notice(&format!(
            "the calibration samples spread by {:.0}% (over {:.0}%): the machine changed speed during the batch",
            100.0 * calibration.spread().unwrap_or(0.0),
            100.0 * crate::calibration::SPREAD_WARNING
        ));
    }
}

/// summary.csv in canonical order, whatever order the workers finished in: the runs judged
/// against the references, those measured here normalized by this batch's calibration (a
/// resumed run keeps its own, or none: it was timed in another batch, on a machine this
/// calibration did not see), then the maps `maps` does not keep dropped. The rows written.
#[allow(clippy::too_many_arguments)]
pub(super) fn judge_and_write(
    plan: &Plan,
    out_dir: &Path,
    mine: &[&PlannedRun],
    meta: &BatchRecord,
    calibration: &Calibration,
    mut finished: Vec<FinishedRun>,
    report: &mut BatchReport,
    progress: &dyn Progress,
) -> Result<Vec<SummaryRow>> {
    finished.sort_by_key(|f| f.index);
    let mut judged: Vec<SummaryRow> = finished.iter().map(|f| f.summary.clone()).collect();
    let stop_of = |energy: &str| plan.runs.iter().find(|p| p.energy == energy).map(|p| p.settings.stop().grad_tol);
    crate::judge::judge_batch(out_dir, &mut judged, &meta.references, &plan.targets, stop_of)?;
    if let Some(line) = verdict_line(&judged, &plan.targets) {
        progress.notice(&line);
    }
    (report.ok, report.not_converged, report.budget) = (0, 0, 0);
    for (f, j) in finished.iter_mut().zip(judged) {
        match j.status {
            Status::Ok => report.ok += 1,
            Status::NotConverged => report.not_converged += 1,
            Status::Budget => report.budget += 1,
            Status::Failed | Status::Skipped => {}
        }
        f.summary = j;
    }
    let mut rows: Vec<SummaryRow> = Vec::with_capacity(finished.len());
    for FinishedRun { index, mut summary, resumed, wrote, .. } in finished {
        if !resumed && summary.time_norm.is_none() {
            summary.time_norm = summary.time_s.and_then(|t| calibration.normalize(t));
            if let Some(key) = wrote {
                sidecar::write(out_dir, &mine[index].stem, &key, &summary)?;
            }
        }
        rows.push(summary);
    }
    crate::run_folder::write_summary(&summary_csv(out_dir), &rows)?;
    // Every map was written as its run finished; now that the groups are complete, drop those
    // `maps` does not keep (`best`: all but one per dataset and energy).
    let missing = crate::run_folder::keep::prune(out_dir, plan.maps, &plan.maps_keep, &rows);
    if !missing.is_empty() {
        progress.notice(&format!(
            "maps = \"{}\" keeps the maps of {} runs whose map this folder does not have (resumed from a batch \
             that did not keep it): {}",
            plan.maps.as_str(),
            missing.len(),
            missing.join(", ")
        ));
    }
    Ok(rows)
}

/// How the judged runs of a batch fared, by verdict, in one line (`None` without any).
fn verdict_line(rows: &[SummaryRow], targets: &crate::convergence::Targets) -> Option<String> {
    let counts: Vec<String> = crate::judge::verdict::Verdict::ALL
        .iter()
        .map(|v| (v, rows.iter().filter(|r| r.verdict == Some(*v)).count()))
        .filter(|(_, n)| *n > 0)
        .map(|(v, n)| format!("{n} {v}"))
        .collect();
    let at = targets.tightest_text();
    (!counts.is_empty()).then(|| format!("judged at {at} against the reference minima: {}", counts.join(", ")))
}

/// The line a finished run prints.
fn run_line(done: usize, total: usize, s: &SummaryRow, resumed: bool) -> String {
    format!(
        "[{done}/{total}] {} {} {}: {}{}{}",
        s.dataset,
        s.energy,
        s.solver,
        if resumed { "resumed, " } else { "" },
        // The harness judges the runs once the batch is over: until then a run has only its
        // own rule's word (a spent budget stays what it is unless the run is solved).
        match s.status {
            st @ (Status::Failed | Status::Skipped | Status::Budget) => st.as_str(),
            _ => "ran",
        },
        match (&s.iterations, &s.final_energy, &s.time_s) {
            (Some(it), Some(e), Some(t)) => format!(" ({}), {it} iterations, E = {e:.8}, {t:.2} s", s.stop_column()),
            _ => format!(": {}", s.error),
        }
    )
}
