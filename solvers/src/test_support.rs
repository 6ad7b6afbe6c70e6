//! What the unit tests of several modules share.

use crate::mesh::{obj::load_obj, Mesh};

/// A mesh of the shared corpus (`$MAPBENCH_MESHES/<name>.obj`), `None` with a note when the
/// variable is not set, so a fresh clone skips the part of a test that needs it.
pub(crate) fn shared_mesh(name: &str) -> Option<Mesh> {
    let Ok(dir) = std::env::var("MAPBENCH_MESHES") else {
        eprintln!("MAPBENCH_MESHES not set: shared mesh {name} skipped");
        return None;
    };
    let path = std::path::Path::new(&dir).join(format!("{name}.obj"));
    Some(load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}
