//! Positional constraints of the `deform` task, in a module of their own: the deform solver
//! reads them and the generated shapes bring them.

/// One positional constraint: vertex `vertex` should go to `target` (file frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Handle {
    /// Index of the constrained vertex.
    pub vertex: usize,
    /// Where the vertex should go, in the mesh file's frame.
    pub target: [f64; 2],
}
