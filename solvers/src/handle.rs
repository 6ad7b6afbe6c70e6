//! Positional constraints of the `deform` task, in a module of their own: the deform solver
//! reads them and the generated shapes bring them.

/// One positional constraint: vertex `vertex` should go to `target` (file frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Handle {
    pub vertex: usize,
    pub target: [f64; 2],
}
