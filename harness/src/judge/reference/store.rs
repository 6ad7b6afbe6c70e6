//! Reference stores: `references.json` with one entry per problem and, beside it in
//! `references/`, each entry's map. The committed store beside the registry is read only;
//! the writable one (the config's `references`, default beside the history database) takes
//! what batches compute or find. An entry is used only once verified against its problem:
//! its map must be there, unchanged, without flips, and its energy must be the stored `E*`
//! (so a hand edit is refused with the reason); of two verified entries the lower is used,
//! and a store only ever takes a lower one.

use super::entry::{Reference, REFERENCE_VERSION};
use crate::judge::problem::Problem;
use crate::plan::paths::Stores;
use crate::run_folder::map::{self, StoredMesh};
use crate::run_folder::write_atomic;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How far a map's energy may be from its entry's `E*` (relative to `max(1, |E*|)`): the
/// energies are summed in a fixed order, so a map reproduces its energy to the last bits.
pub const VERIFY_RTOL: f64 = 1e-12;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoreFile {
    version: u32,
    references: Vec<Reference>,
}

/// One store: its file, its maps' folder and its entries.
pub struct Store {
    pub path: PathBuf,
    pub entries: BTreeMap<String, Reference>,
}

/// The maps' folder of the store `path`: `references/` beside `references.json`.
pub fn maps_dir(path: &Path) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "references".into());
    path.with_file_name(stem)
}

impl Store {
    /// Read `path` (absent: empty; another [`REFERENCE_VERSION`]: no entry applies).
    pub fn read(path: &Path) -> Result<Store> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Store { path: path.to_path_buf(), entries: BTreeMap::new() })
            }
            Err(e) => return Err(e).with_context(|| format!("{}: cannot read the reference store", path.display())),
        };
        let version = serde_json::from_str::<serde_json::Value>(&text)
            .with_context(|| format!("{}: not a reference store", path.display()))?
            .get("version")
            .and_then(|v| v.as_u64());
        let mut entries = BTreeMap::new();
        if version == Some(u64::from(REFERENCE_VERSION)) {
            let file: StoreFile =
                serde_json::from_str(&text).with_context(|| format!("{}: not a reference store", path.display()))?;
            for r in file.references {
                entries.insert(r.key.clone(), r);
            }
        } else if version.is_none() {
            bail!("{}: not a reference store (no version)", path.display());
        }
        Ok(Store { path: path.to_path_buf(), entries })
    }

    /// The folder of this store's maps.
    pub fn maps(&self) -> PathBuf {
        maps_dir(&self.path)
    }

    /// Write the store: its entries sorted by dataset, task, energy and key (stable diffs).
    pub fn write(&self) -> Result<()> {
        let mut references: Vec<Reference> = self.entries.values().cloned().collect();
        references
            .sort_by(|a, b| (&a.dataset, a.task, &a.energy, &a.key).cmp(&(&b.dataset, b.task, &b.energy, &b.key)));
        let text = serde_json::to_string_pretty(&StoreFile { version: REFERENCE_VERSION, references })? + "\n";
        write_atomic(&self.path, text.as_bytes())
    }
}

/// FNV-1a over a map's coordinates (their `f64` bits): what `map_checksum` records.
pub fn map_checksum(x: &[f64]) -> String {
    let mut h = crate::hash::Fnv::new();
    x.iter().for_each(|v| {
        h.word(v.to_bits());
    });
    format!("{:016x}", h.0)
}

/// The map file of an entry: `<dataset>__<task>__<energy>__<key>.uv.gz`, the run folders'
/// format (`mapbench evaluate` scores it with the dataset's mesh).
pub fn map_name(r: &Reference) -> String {
    format!("{}__{}__{}__{}.uv.gz", r.dataset, r.task.as_str(), r.energy, r.key)
}

/// Check `r` (of store `maps`) against its problem: the map `x` (normalized frame) when it
/// holds, else why it is refused.
pub fn verify(r: &Reference, maps: &Path, problem: &Problem) -> std::result::Result<Vec<f64>, String> {
    let same = |a: f64, b: f64| (a - b).abs() <= VERIFY_RTOL * b.abs().max(1.0);
    if !same(r.ideal, problem.ideal) {
        return Err(format!("its isometry value is {}, the energy's is {}", r.ideal, problem.ideal));
    }
    if !same(r.start_energy, problem.e0) {
        return Err(format!("its common start's energy is {}, the problem's is {}", r.start_energy, problem.e0));
    }
    let path = maps.join(&r.map);
    let mesh = &problem.mesh;
    let stored = StoredMesh {
        positions: mesh.positions.clone(),
        faces: mesh.faces.clone(),
        checksum: map::checksum(&mesh.positions, &mesh.faces),
    };
    let uv = match std::fs::symlink_metadata(&path) {
        Ok(m) if m.is_file() => map::read_uv(&path, &stored).map_err(|e| format!("its map: {e:#}"))?,
        Ok(_) => return Err(format!("its map {} is not a regular file", path.display())),
        Err(_) => return Err(format!("its map {} is missing", path.display())),
    };
    let x: Vec<f64> = uv.iter().flat_map(|p| [p[0], p[1]]).collect();
    let sum = map_checksum(&x);
    if sum != r.map_checksum {
        return Err(format!("its map's checksum is {sum}, the entry says {}", r.map_checksum));
    }
    if let Some(v) = x.iter().position(|c| !c.is_finite()) {
        return Err(format!("its map has a non-finite coordinate at vertex {}", v / 2));
    }
    let m = problem.measure(&x);
    if m.flips > 0 {
        return Err(format!("its map flips {} faces", m.flips));
    }
    if !same(m.energy, r.e_star) {
        return Err(format!("e_star = {} but its map's energy is {}", r.e_star, m.energy));
    }
    Ok(x)
}

/// Both stores of a batch.
pub struct Book {
    pub seed: Option<Store>,
    pub own: Store,
    /// Whether [`Book::add`] writes `own` (off with `--no-history`).
    persist: bool,
}

impl Book {
    /// Read both stores.
    pub fn open(stores: &Stores) -> Result<Book> {
        let seed = stores.seed.as_deref().map(Store::read).transpose()?;
        Ok(Book { seed, own: Store::read(&stores.store)?, persist: stores.persist })
    }

    /// The entries for `key`, each with its store's maps folder and whether it is the
    /// writable store's, lowest `E*` first.
    pub fn entries(&self, key: &str) -> Vec<(&Reference, PathBuf, bool)> {
        let mut out: Vec<(&Reference, PathBuf, bool)> = Vec::new();
        if let Some(r) = self.own.entries.get(key) {
            out.push((r, self.own.maps(), true));
        }
        if let Some(seed) = &self.seed {
            if let Some(r) = seed.entries.get(key) {
                out.push((r, seed.maps(), false));
            }
        }
        out.sort_by(|a, b| a.0.e_star.total_cmp(&b.0.e_star));
        out
    }

    /// Add `r` with its map `x` of `mesh` to the writable store, unless it holds one as low
    /// (and as certified) for the key from the same start: the store only gets better. Under a lock on the store (batches and shards
    /// add at once), re-reading what others added since. Without `persist` only this book
    /// remembers it. Returns whether `r` was taken.
    pub fn add(&mut self, r: Reference, x: &[f64], mesh: &solvers::mesh::Mesh) -> Result<bool> {
        // Lower, or as low with a certificate the stored one lacks; or the stored one is stale:
        // its start is not this problem's any more (a chained start whose SD minimum moved),
        // so `verify` refuses it and it would be computed again in every batch.
        let same = |a: f64, b: f64| (a - b).abs() <= VERIFY_RTOL * b.abs().max(1.0);
        let better = |have: Option<&Reference>| {
            have.is_none_or(|h| {
                h.start != r.start
                    || !same(h.start_energy, r.start_energy)
                    || r.e_star < h.e_star
                    || (r.e_star <= h.e_star && r.certificate.certified && !h.certificate.certified)
            })
        };
        if !self.persist {
            let taken = better(self.own.entries.get(&r.key));
            if taken {
                self.own.entries.insert(r.key.clone(), r);
            }
            return Ok(taken);
        }
        let path = self.own.path.clone();
        let dir = path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create folder", dir.display()))?;
        let lock_path = path.with_extension("lock");
        let lock = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .with_context(|| format!("{}: cannot open the store's lock", lock_path.display()))?;
        lock.lock().with_context(|| format!("{}: cannot lock", lock_path.display()))?;
        let mut on_disk = Store::read(&path)?;
        let taken = better(on_disk.entries.get(&r.key));
        if taken {
            write_atomic(&on_disk.maps().join(&r.map), &map::encode_uv(mesh, x))?;
            on_disk.entries.insert(r.key.clone(), r);
            on_disk.write()?;
        }
        drop(lock);
        self.own = on_disk;
        Ok(taken)
    }
}

/// The verified reference of `key` in `book`, lowest first, with its map and whether it is the
/// writable store's; a refused entry gives a `notice` with the reason.
pub fn lookup(book: &Book, key: &str, problem: &Problem, notice: &dyn Fn(&str)) -> Option<(Reference, Vec<f64>, bool)> {
    for (r, maps, own) in book.entries(key) {
        match verify(r, &maps, problem) {
            Ok(x) => return Some((r.clone(), x, own)),
            Err(why) => notice(&format!(
                "reference {} of {} {} {} in {} refused: {why}",
                r.key,
                r.dataset,
                r.task.as_str(),
                r.energy,
                maps_dir(&maps).with_extension("json").display()
            )),
        }
    }
    None
}
