//! `merge SHARD_DIR...`: combine the folders of `run --shard I/N` batches of one config into
//! one run folder, as if the batch had run unsharded, and render its report (`Pages`).
//!
//! Every shard file is read and checked first, so an error names the shard's file; the merged
//! folder is then put together in a staging folder beside the output and moved into place, so
//! a failed merge leaves no partial folder. The history gets the merged batch only when it is
//! complete: every planned run in some shard, and no shard interrupted.

use super::pages::{conclude_history, withdraw, Pages};
use crate::calibration::Calibration;
use crate::external::probe::Probe;
use crate::history::{Decision, HistoryChoice, HistoryOutcome};
use crate::judge::reference::GroupReference;
use crate::run_folder::keep::{self, Maps};
use crate::run_folder::map::{self, legacy_obj_path, mesh_path, uv_path};
use crate::run_folder::meta::{MergedShard, Meta};
use crate::run_folder::reuse::{self, Identity, Reuse};
use crate::run_folder::{
    iterations_csv, read_run, read_summary, run_stem, sidecar, summary_csv, write_atomic, write_summary, SummaryRow,
    OWN_ENTRIES,
};
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What a merge did.
#[derive(Debug)]
pub struct Merged {
    pub out_dir: PathBuf,
    pub runs: usize,
    /// Planned runs no shard has (a shard missing or interrupted).
    pub missing: Vec<String>,
    /// Shards whose batch was interrupted.
    pub interrupted: Vec<PathBuf>,
    /// What became of the merged batch in the history.
    pub history: HistoryOutcome,
}

fn read_meta(dir: &Path) -> Result<Meta> {
    Ok(Meta::read(dir)?)
}

/// One run of a shard, checked: where it is, its row and its place in the batch's plan.
struct ShardRun<'a> {
    dir: &'a Path,
    stem: String,
    index: usize,
    row: SummaryRow,
}

/// Merge `shards` into `out` (default: `reports/<config name>`). `history` picks the database
/// (the config's `history` key, resolved against the shards' config file, unless overridden).
/// An output folder of another batch is refused unless `force`. `pages` renders the report and
/// the trend page.
pub fn merge(
    shards: &[PathBuf],
    out: Option<&Path>,
    history: &HistoryChoice,
    force: bool,
    pages: &dyn Pages,
) -> Result<Merged> {
    let Some(first) = shards.first() else { bail!("merge needs at least one shard folder") };
    let metas: Vec<Meta> = shards.iter().map(|d| read_meta(d)).collect::<Result<_>>()?;
    let identity = batch_identity(shards, &metas)?;
    let order: HashMap<&str, usize> = identity.plan.iter().enumerate().map(|(i, s)| (s.as_str(), i)).collect();
    let out_dir = match out {
        Some(o) => o.to_path_buf(),
        None => {
            crate::names::check_name("config", &identity.config)
                .with_context(|| format!("{}: meta.json", first.display()))?;
            PathBuf::from("reports").join(&identity.config)
        }
    };
    if shards.iter().any(|s| same_dir(s, &out_dir)) {
        bail!("{}: the merged folder must not be one of the shards", out_dir.display());
    }
    let reuse = reuse::check(&out_dir, &identity, force)?;
    // An earlier merge of these same shards into this folder: its batch may be in the history.
    let previous = (reuse == Reuse::Same).then(|| read_meta(&out_dir).ok()).flatten();

    let runs = read_runs(shards, &order)?;
    let present: std::collections::HashSet<&str> = runs.iter().map(|r| r.stem.as_str()).collect();
    let missing: Vec<String> =
        identity.plan.iter().filter(|s| !present.contains(s.as_str())).map(|s| s.to_string()).collect();
    let interrupted: Vec<PathBuf> =
        shards.iter().zip(&metas).filter(|(_, m)| m.interrupted == Some(true)).map(|(d, _)| d.clone()).collect();

    let history_db = {
        let config_dir = metas[0].config_path.as_deref().map(Path::new).and_then(Path::parent).unwrap_or(Path::new(""));
        history.apply(crate::plan::paths::resolve_path(metas[0].config_str("history").map(Path::new), config_dir))
    };
    // The whole folder is made in the staging folder, history outcome and report included,
    // and only then put in place; on any error the staging folder goes, and a batch appended
    // for it is taken out of the history again.
    let staging = staging_dir(&out_dir)?;
    let mut appended = None;
    let mut rows: Vec<SummaryRow> = Vec::new();
    let made = (|| {
        let merged_from = stage(&staging, &runs, &metas, shards, &mut rows)?;
        let decision = if let Some(first) = missing.first() {
            Decision::Skip(format!(
                "{} planned runs are in no shard (first: {first}): the batch is incomplete",
                missing.len()
            ))
        } else if let Some(d) = interrupted.first() {
            Decision::Skip(format!("shard {} was interrupted: the batch is incomplete", d.display()))
        } else {
            already_in(previous.as_ref(), history_db.as_deref(), &merged_from).unwrap_or(Decision::Append)
        };
        crate::run_folder::fill_energy_minus_best(&staging, &rows)?;
        let outcome = conclude_history(pages, history_db.as_deref(), &staging, &out_dir, decision)?;
        appended = Some(outcome.clone());
        pages.report(&staging, &rows)?;
        install(&staging, &out_dir, reuse)?;
        Ok::<_, anyhow::Error>(outcome)
    })();
    let history = match made {
        Ok(outcome) => outcome,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            if let Some(Err(w)) = appended.map(|o| withdraw(pages, &o)) {
                return Err(e.context(format!("the merged batch stays in the history, without its folder: {w}")));
            }
            return Err(e);
        }
    };
    Ok(Merged { out_dir, runs: rows.len(), missing, interrupted, history })
}

/// The batch the shards are of: every shard run from the same config, `--only` and
/// `--repeat` as the first.
fn batch_identity(shards: &[PathBuf], metas: &[Meta]) -> Result<Identity> {
    let first = &shards[0];
    let (config, plan) = (&metas[0].config, &metas[0].plan);
    for (dir, m) in shards.iter().zip(metas).skip(1) {
        if &m.config != config || &m.plan != plan || m.repeat != metas[0].repeat {
            bail!(
                "{}: was run from a different config, --only or --repeat than {} (merge shards of one batch)",
                dir.display(),
                first.display()
            );
        }
    }
    let mut identity = Identity::of_meta(&metas[0])
        .with_context(|| format!("{}: meta.json has no plan (written before shards existed)", first.display()))?;
    identity.shard = None;
    Ok(identity)
}

/// Every shard's runs and files, read and checked where they are, in the plan's order; a run
/// outside the plan or in two shards is an error.
fn read_runs<'a>(shards: &'a [PathBuf], order: &HashMap<&str, usize>) -> Result<Vec<ShardRun<'a>>> {
    let mut runs: Vec<ShardRun> = Vec::new();
    let mut from: HashMap<String, &Path> = HashMap::new();
    for dir in shards {
        for row in read_summary(dir)? {
            let stem = run_stem(&row.dataset, &row.energy, &row.solver);
            let Some(&index) = order.get(stem.as_str()) else {
                bail!("{}: run {stem} is not in the batch's plan", dir.display());
            };
            if let Some(other) = from.insert(stem.clone(), dir) {
                bail!("run {stem} is in both {} and {}", other.display(), dir.display());
            }
            check_files(dir, &stem, &row)?;
            runs.push(ShardRun { dir, stem, index, row });
        }
    }
    runs.sort_by_key(|r| r.index);
    Ok(runs)
}

/// The shards' external solvers, each (name, version, availability) once: a shard that probed
/// another version of a solver adds a second entry, which the report shows.
fn merged_external(metas: &[Meta]) -> Option<serde_json::Value> {
    let mut all: Vec<Probe> = Vec::new();
    for m in metas {
        let theirs: Vec<Probe> = m.external.clone().and_then(|v| serde_json::from_value(v).ok()).unwrap_or_default();
        for p in theirs {
            if !all.contains(&p) {
                all.push(p);
            }
        }
    }
    (!all.is_empty()).then(|| serde_json::to_value(&all).ok()).flatten()
}

/// [`Decision::AlreadyIn`] when the folder's earlier merge (`previous`, its `meta.json`) was
/// of the same shards (the same `merged_from`) and its batch is in `db`.
fn already_in(previous: Option<&Meta>, db: Option<&Path>, merged_from: &[MergedShard]) -> Option<Decision> {
    let previous = previous?;
    if previous.merged_from.as_deref() != Some(merged_from) {
        return None;
    }
    let outcome: HistoryOutcome = serde_json::from_value(previous.history_outcome.clone()?).ok()?;
    let (was, batch_id, trend) = outcome.in_history()?;
    (Some(was) == db.map(crate::paths::absolute).as_deref())
        .then(|| Decision::AlreadyIn { batch_id, trend: trend.cloned() })
}

/// A shard's files of one run, read as the report will read them: the per-iteration CSV
/// (complete, for a run that ran) and the map with its mesh, where the shard has one.
fn check_files(dir: &Path, stem: &str, row: &SummaryRow) -> Result<()> {
    if row.iterations.is_some() || iterations_csv(dir, stem).exists() {
        read_run(dir, row)?;
    }
    if uv_path(dir, stem).is_file() {
        map::read(dir, &row.dataset, stem)?;
    }
    Ok(())
}

/// `.<name>.merging-<pid>` beside `out`, new and empty.
fn staging_dir(out: &Path) -> Result<PathBuf> {
    sibling(out, "merging")
}

/// Write the merged folder into `staging`: each run's files, the summary in the plan's order
/// (its runs judged again as one batch: a run of one shard may lower the reference of a
/// run of another; left in `rows`), the maps `maps` keeps, and `meta.json` with every
/// shard's provenance (`merged_from`, which is returned).
fn stage(
    staging: &Path,
    runs: &[ShardRun],
    metas: &[Meta],
    shards: &[PathBuf],
    rows: &mut Vec<SummaryRow>,
) -> Result<Vec<MergedShard>> {
    let mut meshes_copied: std::collections::HashSet<&str> = Default::default();
    for r in runs {
        // The dataset's mesh copy is the same in every shard (the runs' keys hash the mesh).
        let files =
            [iterations_csv, sidecar::path, uv_path, legacy_obj_path].map(|f| (f(r.dir, &r.stem), f(staging, &r.stem)));
        let mesh = (mesh_path(r.dir, &r.row.dataset), mesh_path(staging, &r.row.dataset));
        let new_mesh = mesh.0.is_file() && meshes_copied.insert(&r.row.dataset);
        for (src, dst) in files.into_iter().chain(new_mesh.then_some(mesh)) {
            if src.is_file() {
                let bytes = std::fs::read(&src).with_context(|| format!("{}: cannot read", src.display()))?;
                write_atomic(&dst, &bytes)?;
            }
        }
    }
    *rows = runs.iter().map(|r| r.row.clone()).collect();
    let references = lowest_references(metas);
    let targets = metas[0].targets();
    let grad_tol = |energy: &str| metas[0].stop_per_energy.as_ref()?.get(energy)?.grad_tol;
    crate::judge::judge_batch(staging, rows, &references, &targets, grad_tol)?;
    write_summary(&summary_csv(staging), rows)?;
    // Each shard kept its own best per group; the merged folder keeps the batch's.
    keep::prune(staging, Maps::of_meta(&metas[0]), metas[0].maps_keep.as_deref().unwrap_or_default(), rows);
    let merged_from: Vec<MergedShard> = shards
        .iter()
        .zip(metas)
        .map(|(d, m)| MergedShard {
            calibration: m.calibration.clone(),
            dir: crate::paths::absolute(d).display().to_string(),
            ended_unix: m.ended_unix,
            git_dirty: m.git_dirty,
            git_revision: m.git_revision.clone(),
            hardware: m.hardware.clone(),
            host: m.host.clone(),
            interrupted: m.interrupted,
            shard: m.shard.clone(),
            started_unix: m.started_unix,
        })
        .collect();
    merged_meta(metas, &references, &merged_from)?.write(staging)?;
    Ok(merged_from)
}

/// Each group's lowest reference over the shards: a shard whose run lowered a group's
/// reference has the lowest, and every run of the batch is judged by it.
fn lowest_references(metas: &[Meta]) -> Vec<GroupReference> {
    let mut references: Vec<GroupReference> = Vec::new();
    for m in metas {
        let theirs: Vec<GroupReference> =
            m.references.clone().and_then(|r| serde_json::from_value(r).ok()).unwrap_or_default();
        for g in theirs {
            match references.iter_mut().find(|r| r.dataset == g.dataset && r.energy == g.energy) {
                Some(r) if g.e_star.zip(r.e_star).is_some_and(|(new, old)| new < old) => *r = g,
                Some(_) => {}
                None => references.push(g),
            }
        }
    }
    references
}

/// The merged folder's `meta.json`: the first shard's, with the batch's references, every
/// shard's provenance, times and calibration samples.
fn merged_meta(metas: &[Meta], references: &[GroupReference], merged_from: &[MergedShard]) -> Result<Meta> {
    let mut meta = metas[0].clone();
    meta.shard = None;
    meta.references = Some(serde_json::to_value(references)?);
    meta.merged_from = Some(merged_from.to_vec());
    // One machine for the batch only when every shard ran on it.
    let first = metas[0].hardware.as_ref();
    meta.hardware = first.filter(|h| metas.iter().all(|m| m.hardware.as_ref() == Some(*h))).cloned();
    meta.external = merged_external(metas);
    let ends: Vec<Option<u64>> = metas.iter().map(|m| m.ended_unix).collect();
    meta.started_unix = metas.iter().filter_map(|m| m.started_unix).min();
    meta.ended_unix = if ends.iter().all(Option::is_some) { ends.iter().flatten().max().copied() } else { None };
    meta.interrupted = Some(metas.iter().any(|m| m.interrupted == Some(true)));
    // Set by the history's outcome once the folder is in place.
    meta.history = None;
    meta.history_outcome = None;
    // Every shard's runs keep the time_norm of their own shard's calibration; the merged
    // folder's calibration holds all the samples, so its spread shows how far the shards'
    // machines (or moments) differed.
    let mut calibration = Calibration::new();
    for c in metas.iter().filter_map(|m| m.calibration.as_ref()) {
        calibration.samples_s.extend(c.samples_s.iter().copied());
    }
    meta.calibration_median_s = calibration.median_s();
    meta.calibration_spread = calibration.spread();
    meta.calibration = Some(calibration);
    Ok(meta)
}

/// Move the staged folder to `out`: a rename when `out` is new; else `out`'s own entries (an
/// earlier merge of this batch, or another batch's with `--force`) are moved aside, the staged
/// ones moved in, and the ones aside deleted; on a failure every entry goes back where it was.
/// The rest of `out` is left as it is.
fn install(staging: &Path, out: &Path, reuse: Reuse) -> Result<()> {
    if !out.exists() {
        if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).with_context(|| format!("{}: cannot create", parent.display()))?;
        }
        return std::fs::rename(staging, out).with_context(|| format!("{}: cannot move into place", out.display()));
    }
    let aside = sibling(out, "replaced")?;
    let mut moved_aside: Vec<&str> = Vec::new();
    let mut moved_in: Vec<std::ffi::OsString> = Vec::new();
    let mut moves = || -> Result<()> {
        if reuse != Reuse::Fresh {
            for entry in OWN_ENTRIES {
                let from = out.join(entry);
                if std::fs::symlink_metadata(&from).is_ok() {
                    let to = aside.join(entry);
                    std::fs::rename(&from, &to).with_context(|| format!("{}: cannot move aside", from.display()))?;
                    moved_aside.push(entry);
                }
            }
        }
        for entry in std::fs::read_dir(staging).with_context(|| format!("{}: cannot read", staging.display()))? {
            let name = entry?.file_name();
            let to = out.join(&name);
            std::fs::rename(staging.join(&name), &to)
                .with_context(|| format!("{}: cannot move into place", to.display()))?;
            moved_in.push(name);
        }
        Ok(())
    };
    let moved = moves();
    if moved.is_err() {
        for name in &moved_in {
            let _ = std::fs::rename(out.join(name), staging.join(name));
        }
        for entry in &moved_aside {
            let _ = std::fs::rename(aside.join(entry), out.join(entry));
        }
    }
    let _ = std::fs::remove_dir_all(&aside);
    moved?;
    std::fs::remove_dir(staging).with_context(|| format!("{}: cannot remove", staging.display()))
}

/// `.<name>.<what>-<pid>` beside `out`, new and empty: on the same file system as `out`'s
/// folder, so entries move by rename.
fn sibling(out: &Path, what: &str) -> Result<PathBuf> {
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "merged".into());
    let parent = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let dir = parent.join(format!(".{name}.{what}-{}", std::process::id()));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("{}: cannot clear", dir.display()))?;
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    Ok(dir)
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, text: &str) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    #[test]
    fn install_replaces_own_entries_and_puts_everything_back_when_a_move_fails() {
        let tmp = tempfile::tempdir().unwrap();
        let (out, staging) = (tmp.path().join("out"), tmp.path().join(".out.merging-1"));
        write(&out.join("summary.csv"), "old");
        write(&out.join("runs/a.csv"), "old");
        write(&out.join("notes/mine.txt"), "mine");
        write(&staging.join("summary.csv"), "new");
        write(&staging.join("runs/b.csv"), "new");
        // A staged entry that cannot replace the user's non-empty folder of the same name.
        write(&staging.join("notes/x"), "staged");
        assert!(install(&staging, &out, Reuse::Same).is_err());
        assert_eq!(std::fs::read_to_string(out.join("summary.csv")).unwrap(), "old");
        assert!(out.join("runs/a.csv").is_file() && !out.join("runs/b.csv").exists());
        assert_eq!(std::fs::read_to_string(staging.join("summary.csv")).unwrap(), "new", "moved back");
        assert_eq!(std::fs::read_to_string(out.join("notes/mine.txt")).unwrap(), "mine");
        // without the conflict: the new entries in, the old ones gone, the user's kept
        std::fs::remove_dir_all(staging.join("notes")).unwrap();
        install(&staging, &out, Reuse::Same).unwrap();
        assert_eq!(std::fs::read_to_string(out.join("summary.csv")).unwrap(), "new");
        assert!(out.join("runs/b.csv").is_file() && !out.join("runs/a.csv").exists());
        assert!(out.join("notes/mine.txt").is_file() && !staging.exists());
        let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, ["out"], "nothing aside is left");
    }
}
