//! `merge SHARD_DIR...`: combine the folders of `run --shard I/N` batches of one config into
//! one run folder, as if the batch had run unsharded, and render its report.

use crate::calibration::Calibration;
use crate::history::HistoryChoice;
use crate::run_folder::keep::{self, Maps};
use crate::run_folder::map::{legacy_obj_path, mesh_path, uv_path};
use crate::run_folder::{
    iterations_csv, meta_json, read_summary, run_stem, sidecar, summary_csv, write_atomic, write_summary, SummaryRow,
};
use anyhow::{bail, Context, Result};
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What a merge did.
#[derive(Debug)]
pub struct Merged {
    pub out_dir: PathBuf,
    pub runs: usize,
    /// Planned runs no shard has (a shard missing or interrupted).
    pub missing: Vec<String>,
    /// The history database the merged batch is to be appended to (`meta.json`'s `history`).
    pub history: Option<PathBuf>,
}

fn read_meta(dir: &Path) -> Result<Value> {
    let path = meta_json(dir);
    let text = std::fs::read_to_string(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", path.display()))
}

/// Merge `shards` into `out` (default: `reports/<config name>`). `history` picks the database
/// recorded in the merged `meta.json` (the config's `history` key, resolved against the
/// shards' config file, unless overridden); the caller appends to it.
pub fn merge(shards: &[PathBuf], out: Option<&Path>, history: &HistoryChoice) -> Result<Merged> {
    let Some(first) = shards.first() else { bail!("merge needs at least one shard folder") };
    let metas: Vec<Value> = shards.iter().map(|d| read_meta(d)).collect::<Result<_>>()?;
    let (config, plan) = (&metas[0]["config"], &metas[0]["plan"]);
    for (dir, m) in shards.iter().zip(&metas).skip(1) {
        if &m["config"] != config || &m["plan"] != plan || m["repeat"] != metas[0]["repeat"] {
            bail!(
                "{}: was run from a different config, --only or --repeat than {} (merge shards of one batch)",
                dir.display(),
                first.display()
            );
        }
    }
    let order: HashMap<String, usize> = plan
        .as_array()
        .with_context(|| format!("{}: meta.json has no plan (written before shards existed)", first.display()))?
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.as_str().map(|s| (s.to_string(), i)))
        .collect();
    let out_dir = match out {
        Some(o) => o.to_path_buf(),
        None => {
            let name = config["name"].as_str().unwrap_or("merged");
            crate::plan::names::check_name("config", name)
                .with_context(|| format!("{}: meta.json", first.display()))?;
            PathBuf::from("reports").join(name)
        }
    };
    if shards.iter().any(|s| same_dir(s, &out_dir)) {
        bail!("{}: the merged folder must not be one of the shards", out_dir.display());
    }
    let mut rows: Vec<(usize, SummaryRow)> = Vec::new();
    let mut from: HashMap<String, &Path> = HashMap::new();
    let mut meshes_copied: std::collections::HashSet<String> = Default::default();
    for dir in shards {
        for row in read_summary(dir)? {
            let stem = run_stem(&row.dataset, &row.energy, &row.solver);
            let Some(&i) = order.get(&stem) else {
                bail!("{}: run {stem} is not in the batch's plan", dir.display());
            };
            if let Some(other) = from.insert(stem.clone(), dir) {
                bail!("run {stem} is in both {} and {}", other.display(), dir.display());
            }
            // The dataset's mesh copy is the same in every shard (the runs' keys hash the mesh).
            let files =
                [iterations_csv, sidecar::path, uv_path, legacy_obj_path].map(|f| (f(dir, &stem), f(&out_dir, &stem)));
            let mesh = (mesh_path(dir, &row.dataset), mesh_path(&out_dir, &row.dataset));
            let new_mesh = mesh.0.is_file() && meshes_copied.insert(row.dataset.clone());
            for (src, dst) in files.into_iter().chain(new_mesh.then_some(mesh)) {
                if src.is_file() {
                    let bytes = std::fs::read(&src).with_context(|| format!("{}: cannot read", src.display()))?;
                    write_atomic(&dst, &bytes)?;
                }
            }
            rows.push((i, row));
        }
    }
    rows.sort_by_key(|(i, _)| *i);
    let rows: Vec<SummaryRow> = rows.into_iter().map(|(_, r)| r).collect();
    let mut missing: Vec<(usize, String)> =
        order.iter().filter(|(s, _)| !from.contains_key(*s)).map(|(s, &i)| (i, s.clone())).collect();
    missing.sort();
    write_summary(&summary_csv(&out_dir), &rows)?;
    // Each shard kept its own best per group; the merged folder keeps the batch's.
    keep::prune(&out_dir, Maps::of_meta(&metas[0]), &rows);
    let mut meta = metas[0].clone();
    meta["shard"] = Value::Null;
    // The shards were not appended (each is part of a batch); the merged batch is.
    let config_dir = metas[0]["config_path"].as_str().map(Path::new).and_then(Path::parent).unwrap_or(Path::new(""));
    let key = config["history"].as_str().map(Path::new);
    let history = history.apply(crate::history::resolve_path(key, config_dir));
    meta["history"] = history.as_ref().map(|p| crate::history::absolute(p).display().to_string()).into();
    meta["merged_from"] = Value::Array(
        shards
            .iter()
            .zip(&metas)
            .map(|(d, m)| {
                serde_json::json!({
                    "dir": d.display().to_string(), "shard": m["shard"], "host": m["host"],
                    "git_revision": m["git_revision"], "git_dirty": m["git_dirty"],
                    "started_unix": m["started_unix"], "ended_unix": m["ended_unix"],
                    "interrupted": m["interrupted"], "calibration": m["calibration"],
                })
            })
            .collect(),
    );
    let starts = metas.iter().filter_map(|m| m["started_unix"].as_u64());
    let ends: Vec<Option<u64>> = metas.iter().map(|m| m["ended_unix"].as_u64()).collect();
    meta["started_unix"] = starts.min().into();
    meta["ended_unix"] =
        if ends.iter().all(Option::is_some) { ends.iter().flatten().max().copied().into() } else { Value::Null };
    meta["interrupted"] = metas.iter().any(|m| m["interrupted"] == Value::Bool(true)).into();
    // Every shard's runs keep the time_norm of their own shard's calibration; the merged
    // folder's calibration holds all the samples, so its spread shows how far the shards'
    // machines (or moments) differed.
    let mut calibration = Calibration::new();
    for m in &metas {
        if let Ok(c) = serde_json::from_value::<Calibration>(m["calibration"].clone()) {
            calibration.samples_s.extend(c.samples_s);
        }
    }
    meta["calibration"] = serde_json::to_value(&calibration)?;
    meta["calibration_median_s"] = calibration.median_s().into();
    meta["calibration_spread"] = calibration.spread().into();
    write_atomic(&meta_json(&out_dir), serde_json::to_string_pretty(&meta)?.as_bytes())?;
    crate::report::refresh(&out_dir, &rows)?;
    Ok(Merged { out_dir, runs: rows.len(), missing: missing.into_iter().map(|(_, s)| s).collect(), history })
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}
