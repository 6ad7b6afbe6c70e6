//! `map RUN_DIR [RUN]...`: the classic OBJ of stored final maps (the source mesh as `v`, the
//! map as `vt`, faces `f a/a b/b c/c`), joined from the run folder's compact files
//! (`uv/<run>.uv.gz` and `meshes/<dataset>.obj.gz`), so any OBJ viewer shows a map as a
//! texture of its mesh.

use crate::output::Output;
use crate::plan::select::glob_match;
use crate::run_folder::keep::Maps;
use crate::run_folder::map::{self, StoredMesh};
use crate::run_folder::{read_summary, run_stem, write_atomic};
use anyhow::{bail, Result};
use std::collections::HashMap;
use std::path::Path;

/// Where the OBJs go.
pub enum Dest<'a> {
    /// One run's OBJ, to this file or standard output.
    File(&'a Output),
    /// `<run>.obj` for each selected run, into this folder.
    Folder(&'a Path),
}

/// What an export did.
#[derive(Debug, Default, PartialEq)]
pub struct Exported {
    /// Where each OBJ went (a file, or standard output).
    pub written: Vec<String>,
    /// Selected runs (finished ones) whose map the folder did not keep.
    pub missing: Vec<String>,
}

/// Write the OBJ of every run of `run_dir`'s summary whose `<dataset>__<energy>__<solver>`
/// matches one of `runs` (globs; none: every run). A selection that matches no run is an
/// error, and so is `Dest::File` with more than one selected run that has a map.
pub fn export_maps(run_dir: &Path, runs: &[String], dest: Dest) -> Result<Exported> {
    match dest {
        Dest::File(f) => f.check()?,
        Dest::Folder(d) => crate::output::check_folder(d)?,
    }
    let rows = read_summary(run_dir)?;
    let selected: Vec<_> = rows
        .iter()
        .map(|r| (r, run_stem(&r.dataset, &r.energy, &r.solver)))
        .filter(|(_, s)| runs.is_empty() || runs.iter().any(|g| glob_match(g, s)))
        .collect();
    if selected.is_empty() {
        bail!("{}: no run matches {}", run_dir.display(), runs.join(" "));
    }
    let mut meshes: HashMap<String, StoredMesh> = HashMap::new();
    let mut maps = Vec::new();
    let mut out = Exported::default();
    for (r, stem) in &selected {
        let mesh = || -> Result<StoredMesh> {
            if let Some(m) = meshes.get(&r.dataset) {
                return Ok(m.clone());
            }
            let m = map::read_mesh(&map::mesh_path(run_dir, &r.dataset))?;
            meshes.insert(r.dataset.clone(), m.clone());
            Ok(m)
        };
        match map::read_with(run_dir, stem, mesh)? {
            Some(m) => maps.push((stem.clone(), m)),
            None if r.iterations.is_some() => out.missing.push(stem.clone()),
            None => {}
        }
    }
    match dest {
        Dest::File(path) => {
            if maps.len() > 1 {
                bail!("--obj writes one map, but {} runs with a map match: give one run, or --out DIR", maps.len());
            }
            if let Some((_, m)) = maps.first() {
                path.write(&map::to_obj(m))?;
                out.written.push(path.to_string());
            }
        }
        Dest::Folder(dir) => {
            for (stem, m) in &maps {
                let path = dir.join(format!("{stem}.obj"));
                write_atomic(&path, &map::to_obj(m))?;
                out.written.push(path.display().to_string());
            }
        }
    }
    Ok(out)
}

/// The line that tells a user how to get the maps a folder did not keep.
pub fn missing_hint(run_dir: &Path) -> String {
    let kept = crate::run_folder::meta::Meta::read(run_dir).ok().map(|m| Maps::of_meta(&m).as_str()).unwrap_or("?");
    format!(
        "the folder keeps maps = \"{kept}\"; runs reproduce their iterates exactly, so set maps = \"all\" and run \
         the config again with --only RUN (into another --out folder) to get the map"
    )
}
