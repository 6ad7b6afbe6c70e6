//! Typed errors of the numerical library. Every message names the mesh source and,
//! where it applies, the element.

use crate::mesh::Problem;

#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: cannot read file: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: malformed OBJ: {message}")]
    Malformed { path: String, message: String },
    #[error("{path}: invalid mesh: {}", crate::mesh::validate::summarize_problems(problems, 10, "; "))]
    Invalid { path: String, problems: Vec<Problem> },
}
