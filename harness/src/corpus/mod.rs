//! The shared mesh corpus on demand (`mapbench corpus fetch`): `corpus.toml` pins each mesh's
//! public source (repository, commit, path) with the SHA-256 of the file downloaded and of the
//! file installed, and names the recipe between them ([`recipe`]). A fetch downloads what is
//! missing ([`download`], resumable), builds and checks every file in a staging folder inside
//! the target, and only when all of them are right moves them into place, each by a rename:
//! a mismatch or a missing source installs nothing. `--from DIR` takes the files from a copy
//! of the corpus instead, checked the same way.

pub mod download;
pub mod mat;
pub mod recipe;

use crate::plan::select::glob_match;
use anyhow::{bail, Context, Result};
use serde::Deserialize;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The layout of `corpus.toml`.
pub const CORPUS_VERSION: u32 = 1;

/// The manifest built into the binary: the repository's `corpus.toml`.
pub const BUILT_IN: &str = include_str!("../../../corpus.toml");

/// Where sources are downloaded from unless `MAPBENCH_CORPUS_URL` says otherwise:
/// `{repository}`, `{commit}` and `{path}` are filled in from the manifest.
pub const DEFAULT_URL: &str = "https://raw.githubusercontent.com/{repository}/{commit}/{path}";

/// The environment variable that replaces [`DEFAULT_URL`] (a mirror, or a test's server).
pub const URL_ENV: &str = "MAPBENCH_CORPUS_URL";

/// The folder inside the target where downloads and built files wait to be installed.
pub const WORK_DIR: &str = ".mapbench-corpus";

/// How a mesh's file is made from its source.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Recipe {
    /// The source OBJ's vertices and triangles, re-exported.
    Obj,
    /// A MATLAB 5 file's `v` and `f` matrices as an OBJ.
    Mat,
    /// One flat 1-to-4 midpoint subdivision of another mesh of the corpus.
    Subdivide,
    /// A GLID cage triangulated with Triangle (Python), with its constraints as a sidecar.
    Glid,
}

impl Recipe {
    /// Its name in `corpus.toml`.
    pub fn as_str(self) -> &'static str {
        match self {
            Recipe::Obj => "obj",
            Recipe::Mat => "mat",
            Recipe::Subdivide => "subdivide",
            Recipe::Glid => "glid",
        }
    }
}

/// One mesh of the corpus.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CorpusEntry {
    pub name: String,
    pub file: String,
    pub recipe: Recipe,
    /// `subdivide`: the mesh it subdivides.
    #[serde(default)]
    pub of: Option<String>,
    pub bytes: u64,
    pub sha256: String,
    /// `glid`: the constraint sets written beside the mesh.
    #[serde(default)]
    pub sidecar: Option<String>,
    #[serde(default)]
    pub sidecar_bytes: Option<u64>,
    #[serde(default)]
    pub sidecar_sha256: Option<String>,
    pub repository: String,
    pub commit: String,
    pub path: String,
    pub source_bytes: u64,
    pub source_sha256: String,
    pub license: String,
}

/// A file the fetch installs: a mesh or a sidecar.
#[derive(Clone, Debug, PartialEq)]
pub struct CorpusFile {
    pub file: String,
    pub bytes: u64,
    pub sha256: String,
}

impl CorpusEntry {
    /// The files it installs: its mesh, then its sidecar.
    pub fn outputs(&self) -> Vec<CorpusFile> {
        let mut out = vec![CorpusFile { file: self.file.clone(), bytes: self.bytes, sha256: self.sha256.clone() }];
        if let (Some(file), Some(bytes), Some(sha256)) = (&self.sidecar, self.sidecar_bytes, &self.sidecar_sha256) {
            out.push(CorpusFile { file: file.clone(), bytes, sha256: sha256.clone() });
        }
        out
    }

    /// The source's address under `template` (see [`DEFAULT_URL`]).
    pub fn url(&self, template: &str) -> String {
        template
            .replace("{repository}", &self.repository)
            .replace("{commit}", &self.commit)
            .replace("{path}", &self.path)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    version: u32,
    #[serde(rename = "mesh")]
    meshes: Vec<CorpusEntry>,
}

/// `corpus.toml`, checked.
#[derive(Clone, Debug)]
pub struct Manifest {
    pub meshes: Vec<CorpusEntry>,
}

impl Manifest {
    /// Parse and check a manifest; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Manifest> {
        let m: ManifestFile =
            toml::from_str(text).with_context(|| format!("{}: not a corpus manifest", path.display()))?;
        if m.version != CORPUS_VERSION {
            bail!("{}: corpus manifest version {} (this mapbench reads {CORPUS_VERSION})", path.display(), m.version);
        }
        let mut seen = std::collections::BTreeSet::new();
        for (k, e) in m.meshes.iter().enumerate() {
            let at = |what: String| anyhow::anyhow!("{}: mesh {:?}: {what}", path.display(), e.name);
            crate::names::check_name("mesh", &e.name).map_err(|err| at(format!("{err:#}")))?;
            for o in e.outputs() {
                crate::names::check_name("file", &o.file).map_err(|err| at(format!("{err:#}")))?;
                if !seen.insert(o.file.clone()) {
                    return Err(at(format!("{} is installed twice", o.file)));
                }
                if !is_sha256(&o.sha256) {
                    return Err(at(format!("{}: `{}` is not a SHA-256 (64 hex digits)", o.file, o.sha256)));
                }
            }
            if !is_sha256(&e.source_sha256) {
                return Err(at(format!("source_sha256 `{}` is not a SHA-256", e.source_sha256)));
            }
            match (e.recipe, &e.of) {
                (Recipe::Subdivide, Some(of)) if m.meshes[..k].iter().any(|x| &x.name == of) => {}
                (Recipe::Subdivide, _) => return Err(at("`subdivide` needs `of`, a mesh listed before it".into())),
                (_, Some(_)) => return Err(at("`of` belongs to the subdivide recipe".into())),
                _ => {}
            }
            let sidecar = [e.sidecar.is_some(), e.sidecar_bytes.is_some(), e.sidecar_sha256.is_some()];
            if (e.recipe == Recipe::Glid) != (sidecar == [true; 3])
                || (e.recipe != Recipe::Glid && sidecar.contains(&true))
            {
                return Err(at(
                    "the glid recipe, and it alone, has a sidecar (sidecar, sidecar_bytes, sidecar_sha256)".into(),
                ));
            }
        }
        Ok(Manifest { meshes: m.meshes })
    }

    /// The manifest built into the binary.
    pub fn built_in() -> Result<Manifest> {
        Manifest::parse(BUILT_IN, Path::new("corpus.toml (built in)"))
    }

    /// The meshes whose names match one of `only` (globs; none: all), with the meshes they
    /// are made from ahead of them.
    pub fn select(&self, only: &[String]) -> Result<Vec<&CorpusEntry>> {
        let chosen = |e: &CorpusEntry| only.is_empty() || only.iter().any(|g| glob_match(g, &e.name));
        let mut wanted: Vec<bool> = self.meshes.iter().map(chosen).collect();
        if !wanted.contains(&true) {
            bail!("no mesh of the corpus matches {}", only.join(" "));
        }
        for k in (0..self.meshes.len()).rev() {
            if let (true, Some(of)) = (wanted[k], &self.meshes[k].of) {
                let j = self.meshes.iter().position(|x| &x.name == of).unwrap_or(k);
                wanted[j] = true;
            }
        }
        Ok(self.meshes.iter().zip(wanted).filter(|(_, w)| *w).map(|(e, _)| e).collect())
    }
}

fn is_sha256(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// The SHA-256 of `bytes`, as 64 lower-case hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// The SHA-256 of the file at `path`, read in pieces.
pub fn sha256_file(path: &Path) -> Result<String> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f.read(&mut buf).with_context(|| format!("{}: cannot read", path.display()))?;
        if n == 0 {
            return Ok(hex(&h.finalize()));
        }
        h.update(&buf[..n]);
    }
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

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
