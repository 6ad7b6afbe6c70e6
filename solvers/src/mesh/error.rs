//! Why a mesh could not be read or used.

use super::defect::{summarize_problems, Defect};

/// Why a mesh could not be read or used. Every message names the mesh source.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("{path}: cannot read file: {source}")]
    Io {
        /// The file path, as displayed.
        path: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not an OBJ triangle mesh the reader accepts.
    #[error("{path}: malformed OBJ: {message}")]
    Malformed {
        /// The mesh source.
        path: String,
        /// What is wrong, naming the line when there is one.
        message: String,
    },
    /// The mesh was read but failed validation.
    #[error("{path}: invalid mesh: {}", summarize_problems(problems, 10, "; "))]
    Invalid {
        /// The mesh source (file path or `generated:<name>`).
        path: String,
        /// Every defect found, as in [`ValidationReport::problems`](super::ValidationReport::problems).
        problems: Vec<Defect>,
    },
}
