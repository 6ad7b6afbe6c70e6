//! `corpus.toml`, the manifest of the shared corpus: each mesh's file, its pinned public source
//! and the recipe between them, parsed and checked.

use super::sha256::is_sha256;
use crate::plan::select::glob_match;
use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::Path;

/// The layout of `corpus.toml`.
pub const CORPUS_VERSION: u32 = 1;

/// The manifest built into the binary: the repository's `corpus.toml`.
pub const BUILT_IN: &str = include_str!("../../../corpus.toml");

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

    /// The source's address under `template` (see [`DEFAULT_URL`](super::DEFAULT_URL)).
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
