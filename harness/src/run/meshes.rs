//! Meshes shared by the workers of a batch, each with the symbolic analyses its runs share.

use crate::plan::registry::Dataset;
use anyhow::Result;
use solvers::linear::AnalysisCache;
use solvers::mesh::Mesh;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// A dataset's mesh and what its runs share: the symbolic analyses of their systems.
pub(super) struct Loaded {
    pub mesh: Result<Mesh>,
    pub analyses: Arc<AnalysisCache>,
    /// `meshes/<dataset>.obj.gz`'s bytes, encoded by the first run that keeps a map.
    mesh_file: OnceLock<Arc<Vec<u8>>>,
}

impl Loaded {
    /// The mesh's file for the run folder (`None` when it did not load).
    pub fn mesh_file(&self) -> Option<Arc<Vec<u8>>> {
        let mesh = self.mesh.as_ref().ok()?;
        Some(self.mesh_file.get_or_init(|| Arc::new(crate::run_folder::map::encode_mesh(mesh))).clone())
    }
}

/// Meshes shared by the workers: loaded by the first run that needs one, dropped (with their
/// analyses) after the dataset's last run.
pub(super) struct MeshCache {
    slots: Vec<Mutex<Option<Arc<Loaded>>>>,
    remaining: Vec<AtomicUsize>,
}

impl MeshCache {
    /// A cache for the runs on `datasets` (one index per run) of `n_datasets`.
    pub fn new(datasets: impl Iterator<Item = usize>, n_datasets: usize) -> MeshCache {
        let remaining: Vec<AtomicUsize> = (0..n_datasets).map(|_| AtomicUsize::new(0)).collect();
        for d in datasets {
            remaining[d].fetch_add(1, Ordering::Relaxed);
        }
        MeshCache { slots: (0..n_datasets).map(|_| Mutex::new(None)).collect(), remaining }
    }

    pub fn get(&self, d: usize, ds: &Dataset) -> Arc<Loaded> {
        let mut slot = self.slots[d].lock().unwrap_or_else(|e| e.into_inner());
        slot.get_or_insert_with(|| {
            Arc::new(Loaded { mesh: ds.load(), analyses: Default::default(), mesh_file: OnceLock::new() })
        })
        .clone()
    }

    pub fn done(&self, d: usize) {
        if self.remaining[d].fetch_sub(1, Ordering::AcqRel) == 1 {
            *self.slots[d].lock().unwrap_or_else(|e| e.into_inner()) = None;
        }
    }
}
