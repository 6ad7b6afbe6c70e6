//! The shared mesh corpus on demand (`mapbench corpus fetch`): `corpus.toml` pins each mesh's
//! public source (repository, commit, path) with the SHA-256 of the file downloaded and of the
//! file installed, and names the recipe between them ([`recipe`]). A fetch downloads what is
//! missing ([`download`], resumable), builds and checks every file in a staging folder inside
//! the target, and only when all of them are right moves them into place, each by a rename:
//! a mismatch or a missing source installs nothing. `--from DIR` takes the files from a copy
//! of the corpus instead, checked the same way.

pub mod download;
mod manifest;
pub mod mat;
pub mod recipe;
mod sha256;

pub use manifest::{CorpusEntry, CorpusFile, Manifest, Recipe, BUILT_IN, CORPUS_VERSION};
pub use sha256::{sha256_file, sha256_hex};

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Where sources are downloaded from unless `MAPBENCH_CORPUS_URL` says otherwise:
/// `{repository}`, `{commit}` and `{path}` are filled in from the manifest.
pub const DEFAULT_URL: &str = "https://raw.githubusercontent.com/{repository}/{commit}/{path}";

/// The environment variable that replaces [`DEFAULT_URL`] (a mirror, or a test's server).
pub const URL_ENV: &str = "MAPBENCH_CORPUS_URL";

/// The folder inside the target where downloads and built files wait to be installed.
pub const WORK_DIR: &str = ".mapbench-corpus";

/// Where the files come from.
#[derive(Clone, Debug)]
pub enum From {
    /// Each source downloaded from the address template (see [`DEFAULT_URL`]) and the recipe
    /// applied.
    Sources { url: String },
    /// A folder holding the corpus's files (another copy of the corpus).
    Copy(PathBuf),
}

/// What a fetch did.
#[derive(Debug, Default)]
pub struct Fetched {
    /// Files moved into the target.
    pub installed: Vec<String>,
    /// Files that were there already, with the right SHA-256.
    pub present: Vec<String>,
}

/// Install the meshes `entries` (as [`Manifest::select`] gives them) into `to`, from `from`.
/// `say` gets one line per step (the progress). Everything is built and checked under
/// `to/.mapbench-corpus/` first; only when every file is right are they renamed into `to`,
/// and the work folder removed. On an error nothing is installed, and what was downloaded
/// and built so far is kept there, so that the next fetch resumes.
pub fn fetch(entries: &[&CorpusEntry], to: &Path, from: &From, say: &mut dyn FnMut(&str)) -> Result<Fetched> {
    if let From::Copy(dir) = from {
        if !dir.is_dir() {
            bail!("{}: no such folder (--from)", dir.display());
        }
    }
    let work = to.join(WORK_DIR);
    let (staging, downloads) = (work.join("staging"), work.join("downloads"));
    for d in [&staging, &downloads] {
        std::fs::create_dir_all(d).with_context(|| format!("{}: cannot create", d.display()))?;
    }
    let mut done = Fetched::default();
    let mut to_install: Vec<String> = Vec::new();
    let count = entries.len();
    for (k, e) in entries.iter().enumerate() {
        let outputs = e.outputs();
        let at = format!("[{}/{count}] {}", k + 1, e.name);
        // installed already, or built by an earlier fetch that stopped before installing
        let mut pending = Vec::new();
        for o in &outputs {
            if matches(&to.join(&o.file), o)? {
                done.present.push(o.file.clone());
            } else if matches(&staging.join(&o.file), o)? {
                to_install.push(o.file.clone());
            } else {
                pending.push(o.clone());
            }
        }
        if pending.is_empty() {
            say(&format!("{at}: {} (checked)", if to_install.contains(&e.file) { "built before" } else { "present" }));
            continue;
        }
        let made: Vec<(CorpusFile, Vec<u8>)> = match from {
            From::Copy(dir) => copied(e, dir, &pending)?,
            From::Sources { url } => {
                let url = e.url(url);
                let source = download::fetch_file(&url, &downloads, e.source_bytes, &e.source_sha256, &mut |line| {
                    say(&format!("{at}: {line}"))
                })
                .with_context(|| format!("{}: its source", e.name))?;
                let built = recipe::build(e, &source, &|of| {
                    let o = entries.iter().find(|x| x.name == of).map(|x| x.file.clone()).unwrap_or_default();
                    let staged = staging.join(&o);
                    std::fs::read(if staged.is_file() { staged } else { to.join(&o) })
                        .with_context(|| format!("{}: the mesh it is made from, {of}", e.name))
                })
                .with_context(|| format!("{}: the {} recipe", e.name, e.recipe.as_str()))?;
                outputs.iter().cloned().zip(built).filter(|(o, _)| pending.contains(o)).collect()
            }
        };
        for (o, bytes) in made {
            check_pinned(e, &o, &bytes)?;
            crate::run_folder::write_atomic(&staging.join(&o.file), &bytes)?;
            to_install.push(o.file.clone());
        }
        say(&format!("{at}: {} built and checked", e.file));
    }
    for file in &to_install {
        std::fs::rename(staging.join(file), to.join(file))
            .with_context(|| format!("{}: cannot move into {}", file, to.display()))?;
        done.installed.push(file.clone());
    }
    std::fs::remove_dir_all(&work).with_context(|| format!("{}: cannot remove", work.display()))?;
    Ok(done)
}

/// The files `pending` of mesh `e`, read from a copy of the corpus in `dir`.
fn copied(e: &CorpusEntry, dir: &Path, pending: &[CorpusFile]) -> Result<Vec<(CorpusFile, Vec<u8>)>> {
    pending
        .iter()
        .map(|o| {
            let p = dir.join(&o.file);
            std::fs::read(&p)
                .with_context(|| format!("{}: {}: cannot read", e.name, p.display()))
                .map(|b| (o.clone(), b))
        })
        .collect()
}

/// `bytes`, made for the file `o` of mesh `e`, are what the corpus pins (size and SHA-256).
fn check_pinned(e: &CorpusEntry, o: &CorpusFile, bytes: &[u8]) -> Result<()> {
    let got = sha256_hex(bytes);
    if got != o.sha256 || bytes.len() as u64 != o.bytes {
        bail!(
            "{}: {} has SHA-256 {got} ({} bytes), but the corpus pins {} ({} bytes): refused, nothing installed",
            e.name,
            o.file,
            bytes.len(),
            o.sha256,
            o.bytes
        );
    }
    Ok(())
}

/// Whether `path` is the file `o` (its size, then its SHA-256); `false` when it is absent.
fn matches(path: &Path, o: &CorpusFile) -> Result<bool> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() && m.len() == o.bytes => Ok(sha256_file(path)? == o.sha256),
        _ => Ok(false),
    }
}

#[cfg(test)]
mod tests;
