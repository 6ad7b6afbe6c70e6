//! Whether a batch may write into a folder that already has files. A run folder of the same
//! batch (config, planned runs, shard) is reused: `--resume`, a re-run, a new merge of the
//! same shards. One of another config or plan is refused, since its runs, maps and plots would
//! stay beside the new ones and `index.html` would list them; `--force` cleans it (the files
//! of [`OWN_ENTRIES`] only). A non-empty folder mapbench did not write is never touched.

use super::meta::Meta;
use super::{is_run_folder, OWN_ENTRIES};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// What makes a run folder one batch's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    pub config: String,
    /// The planned runs (`--only` applied), in the batch's order.
    pub plan: Vec<String>,
    /// `I/N` of a `--shard` batch.
    pub shard: Option<String>,
}

impl Identity {
    /// The identity `meta.json` records (`None`: a meta.json without one).
    pub fn of_meta(meta: &Meta) -> Option<Identity> {
        Some(Identity { config: meta.config_name()?.to_string(), plan: meta.plan.clone()?, shard: meta.shard.clone() })
    }

    /// How `other` (the folder's batch) differs from this one, in words.
    fn difference(&self, other: &Identity) -> String {
        if other.config != self.config {
            return format!("config \"{}\", not \"{}\"", other.config, self.config);
        }
        if other.shard != self.shard {
            let shard = |s: &Option<String>| s.clone().unwrap_or_else(|| "none".into());
            return format!("shard {}, not {}", shard(&other.shard), shard(&self.shard));
        }
        let first =
            other.plan.iter().find(|s| !self.plan.contains(s)).or(self.plan.iter().find(|s| !other.plan.contains(s)));
        format!(
            "another plan: {} runs, this batch {}{}",
            other.plan.len(),
            self.plan.len(),
            first.map(|s| format!(" ({s} is in only one)")).unwrap_or_else(|| " (in another order)".into())
        )
    }
}

/// What a batch found in its output folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reuse {
    /// New, or empty.
    Fresh,
    /// A run folder of the same batch.
    Same,
    /// A run folder of another batch, to be cleaned ([`clean`]) before it is written
    /// (`--force`).
    Another,
}

/// Decide whether the batch `mine` may write into `dir`: a run folder of another batch only
/// with `force` (the caller then [`clean`]s it).
pub fn check(dir: &Path, mine: &Identity, force: bool) -> Result<Reuse> {
    // A submission's folder (`mapbench submit`) alone is not a batch's result.
    let empty = match std::fs::read_dir(dir) {
        Ok(entries) => entries.flatten().all(|e| e.file_name() == super::SUBMISSION_DIR),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => true,
        Err(e) => return Err(e).with_context(|| format!("{}: cannot read the output folder", dir.display())),
    };
    if empty {
        return Ok(Reuse::Fresh);
    }
    if !is_run_folder(dir) && !only_own_entries(dir) {
        bail!(
            "{}: not empty and not a mapbench run folder (no meta.json and summary.csv); mapbench writes a batch \
             only into a new, empty or run folder (give another --out)",
            dir.display()
        );
    }
    let theirs = Meta::read(dir).ok().and_then(|m| Identity::of_meta(&m));
    if theirs.as_ref() == Some(mine) {
        return Ok(Reuse::Same);
    }
    let what = match &theirs {
        Some(t) => mine.difference(t),
        None => "a meta.json that names no batch".into(),
    };
    if !force {
        bail!(
            "{}: a run folder of another batch ({what}); its runs would stay beside this batch's. Give another \
             --out, or --force to delete its results first",
            dir.display()
        );
    }
    Ok(Reuse::Another)
}

/// Whether every entry of `dir` is one mapbench writes ([`OWN_ENTRIES`], or a temporary of
/// `write_atomic`): a batch stopped before its `meta.json` (a run folder of no known batch).
fn only_own_entries(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries.flatten().all(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            OWN_ENTRIES.contains(&name.as_str())
                || name == super::SUBMISSION_DIR
                || (name.starts_with('.') && name.contains(".tmp"))
        })
    })
}

/// Delete a run folder's own files and folders ([`OWN_ENTRIES`]), nothing else.
pub fn clean(dir: &Path) -> Result<()> {
    for entry in OWN_ENTRIES {
        let path = dir.join(entry);
        let removed = match std::fs::symlink_metadata(&path) {
            Ok(m) if m.is_dir() => std::fs::remove_dir_all(&path),
            Ok(_) => std::fs::remove_file(&path),
            Err(_) => continue,
        };
        removed.with_context(|| format!("{}: cannot delete", path.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::meta_json;

    fn identity(config: &str, plan: &[&str], shard: Option<&str>) -> Identity {
        Identity {
            config: config.into(),
            plan: plan.iter().map(|s| s.to_string()).collect(),
            shard: shard.map(str::to_string),
        }
    }

    /// A run folder of `id` in `dir`, with a run's CSV and a file of the user's.
    fn folder(dir: &Path, id: &Identity) {
        std::fs::create_dir_all(dir.join("runs")).unwrap();
        let meta = serde_json::json!({"config": {"name": id.config}, "plan": id.plan, "shard": id.shard});
        std::fs::write(meta_json(dir), meta.to_string()).unwrap();
        std::fs::write(dir.join("summary.csv"), "dataset\n").unwrap();
        std::fs::write(dir.join("runs/a__sd__cm.csv"), "iter\n").unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    }

    #[test]
    fn the_same_batch_is_reused_another_refused_or_cleaned_and_foreign_folders_left_alone() {
        let tmp = tempfile::tempdir().unwrap();
        let mine = identity("param", &["a__sd__cm", "a__sd__slim"], None);
        assert_eq!(check(&tmp.path().join("new"), &mine, false).unwrap(), Reuse::Fresh);
        assert_eq!(check(tmp.path(), &mine, false).unwrap(), Reuse::Fresh, "empty");
        let dir = tmp.path().join("out");
        folder(&dir, &mine);
        assert_eq!(check(&dir, &mine, false).unwrap(), Reuse::Same);
        for (other, needle) in [
            (identity("deform", &mine.plan.iter().map(String::as_str).collect::<Vec<_>>(), None), "config \"deform\""),
            (identity("param", &["a__sd__cm"], None), "1 runs, this batch 2 (a__sd__slim is in only one)"),
            (identity("param", &["a__sd__slim", "a__sd__cm"], None), "in another order"),
            (identity("param", &["a__sd__cm", "a__sd__slim"], Some("1/2")), "shard 1/2, not none"),
        ] {
            folder(&dir, &other);
            let e = check(&dir, &mine, false).unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("--force"), "{e}");
            assert!(dir.join("runs/a__sd__cm.csv").is_file(), "refused, so untouched");
        }
        assert_eq!(check(&dir, &mine, true).unwrap(), Reuse::Another);
        assert!(dir.join("runs").is_dir(), "checked, not cleaned yet");
        clean(&dir).unwrap();
        assert!(!dir.join("runs").exists() && !dir.join("summary.csv").exists() && !meta_json(&dir).exists());
        assert_eq!(std::fs::read_to_string(dir.join("notes.txt")).unwrap(), "mine", "not mapbench's: kept");
        // only mapbench's own entries, no meta.json (a batch stopped at its start): a run
        // folder of no known batch
        std::fs::create_dir_all(tmp.path().join("stopped/runs")).unwrap();
        let e = check(&tmp.path().join("stopped"), &mine, false).unwrap_err().to_string();
        assert!(e.contains("a meta.json that names no batch") && e.contains("--force"), "{e}");
        assert_eq!(check(&tmp.path().join("stopped"), &mine, true).unwrap(), Reuse::Another);
        // a folder with files but no run folder's markers: refused even with --force
        let e = check(&dir, &mine, true).unwrap_err().to_string();
        assert!(e.contains("not empty and not a mapbench run folder"), "{e}");
        assert_eq!(std::fs::read_to_string(dir.join("notes.txt")).unwrap(), "mine");
    }
}
