//! Triangle meshes: the in-memory type, OBJ input, topology queries and validation.

mod defect;
mod error;
mod handle;
pub mod obj;
pub mod topology;
mod triangle_mesh;
pub mod validate;

pub use defect::Defect;
pub use error::MeshError;
pub use handle::Handle;
pub use obj::load_obj;
pub use triangle_mesh::{signed_area, Mesh};
pub use validate::{validate, ValidationReport};
