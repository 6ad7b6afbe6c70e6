//! Triangle meshes: the in-memory type, OBJ input, topology queries and validation.

pub mod obj;
pub mod topology;
pub mod validate;

pub use obj::load_obj;
pub use validate::{validate, Problem, ValidationReport};

/// A triangle mesh as read from a file or generated.
///
/// Positions are 3D; planar (2D) inputs carry `z = 0`. Faces index `positions` (0-based)
/// and are not checked at construction: run [`validate`] before using a mesh from outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Where the mesh came from (file path or `generated:<name>`), used in every message.
    pub source: String,
    pub positions: Vec<[f64; 3]>,
    pub faces: Vec<[usize; 3]>,
}

impl Mesh {
    pub fn new(source: impl Into<String>, positions: Vec<[f64; 3]>, faces: Vec<[usize; 3]>) -> Self {
        Mesh { source: source.into(), positions, faces }
    }

    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// True when every vertex has `z == 0` (a 2D deformation shape).
    pub fn is_planar(&self) -> bool {
        self.positions.iter().all(|p| p[2] == 0.0)
    }

    /// Unsigned area of face `f` in 3D.
    pub fn face_area(&self, f: usize) -> f64 {
        let [a, b, c] = self.faces[f];
        let (p, q, r) = (self.positions[a], self.positions[b], self.positions[c]);
        let u = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let v = [r[0] - p[0], r[1] - p[1], r[2] - p[2]];
        let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
    }

    pub fn total_area(&self) -> f64 {
        (0..self.n_faces()).map(|f| self.face_area(f)).sum()
    }

    /// Axis-aligned bounding box `(lo, hi)`; `None` for a mesh without vertices.
    pub fn bbox(&self) -> Option<([f64; 3], [f64; 3])> {
        if self.positions.is_empty() {
            return None;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Some((lo, hi))
    }

    /// Length of the bounding-box diagonal (0 for an empty mesh).
    pub fn bbox_diagonal(&self) -> f64 {
        self.bbox().map_or(0.0, |(lo, hi)| {
            ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
        })
    }

    /// Centre on the bounding-box midpoint and scale uniformly to total surface area 1
    /// (the convention of the complex-view reference code, design.md).
    pub fn normalized(&self) -> Mesh {
        let (mid, s) = self.normalization();
        let positions =
            self.positions.iter().map(|p| [(p[0] - mid[0]) * s, (p[1] - mid[1]) * s, (p[2] - mid[2]) * s]).collect();
        Mesh { source: self.source.clone(), positions, faces: self.faces.clone() }
    }

    /// The transform of [`Mesh::normalized`]: `p -> (p - mid) * s`.
    pub fn normalization(&self) -> ([f64; 3], f64) {
        let (lo, hi) = self.bbox().unwrap_or(([0.0; 3], [0.0; 3]));
        let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
        (mid, 1.0 / self.total_area().sqrt())
    }
}
