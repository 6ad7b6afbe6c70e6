//! The in-memory triangle mesh: positions, faces and where they came from.

/// Signed area of a planar triangle, positive when counter-clockwise.
#[inline]
pub fn signed_area(y: [[f64; 2]; 3]) -> f64 {
    0.5 * ((y[1][0] - y[0][0]) * (y[2][1] - y[0][1]) - (y[1][1] - y[0][1]) * (y[2][0] - y[0][0]))
}

/// A triangle mesh as read from a file or generated.
///
/// Positions are 3D; planar (2D) inputs carry `z = 0`. Faces index `positions` (0-based)
/// and are not checked at construction: run [`validate()`](super::validate()) before using a mesh from outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Where the mesh came from (file path or `generated:<name>`), used in every message.
    pub source: String,
    /// Vertex positions, in the source's units until [`Mesh::normalized`].
    pub positions: Vec<[f64; 3]>,
    /// Triangles as three indices into `positions`.
    pub faces: Vec<[usize; 3]>,
}

impl Mesh {
    /// A mesh from its source name, positions and faces, unchecked.
    pub fn new(source: impl Into<String>, positions: Vec<[f64; 3]>, faces: Vec<[usize; 3]>) -> Self {
        Mesh { source: source.into(), positions, faces }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// True when every vertex has `z == 0` (a 2D deformation shape).
    pub fn is_planar(&self) -> bool {
        self.positions.iter().all(|p| p[2] == 0.0)
    }

    /// Unsigned area of face `f` in 3D.
    pub fn face_area(&self, f: usize) -> f64 {
        self.face_area_scaled(f, 1.0)
    }

    /// Unsigned area of face `f` of the mesh scaled by `k` (positions times `k`). With `k` the
    /// inverse of [`Mesh::extent`] the edge vectors are at most 1, so nothing over- or
    /// underflows whatever the file's units; `k = 1` gives exactly [`Mesh::face_area`].
    pub fn face_area_scaled(&self, f: usize, k: f64) -> f64 {
        let [a, b, c] = self.faces[f];
        let (p, q, r) = (self.positions[a], self.positions[b], self.positions[c]);
        let u = [(q[0] - p[0]) * k, (q[1] - p[1]) * k, (q[2] - p[2]) * k];
        let v = [(r[0] - p[0]) * k, (r[1] - p[1]) * k, (r[2] - p[2]) * k];
        let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
    }

    /// Sum of the unsigned face areas in 3D (1 after [`Mesh::normalized`]).
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
        let Some((lo, hi)) = self.bbox() else { return 0.0 };
        let d = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
        let m = self.extent();
        if d.is_normal() || !(m > 0.0) || !m.is_finite() {
            return d;
        }
        // The squares over- or underflowed (coordinates beyond about 1e154 or below 1e-154):
        // the same length measured in units of the largest side.
        m * (((hi[0] - lo[0]) / m).powi(2) + ((hi[1] - lo[1]) / m).powi(2) + ((hi[2] - lo[2]) / m).powi(2)).sqrt()
    }

    /// Largest side of the bounding box (0 for an empty mesh; infinite when the coordinates
    /// span more than an `f64` holds).
    pub fn extent(&self) -> f64 {
        self.bbox().map_or(0.0, |(lo, hi)| (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max))
    }

    /// Centre on the bounding-box midpoint and scale uniformly to total surface area 1
    /// (the convention of the complex-view reference code; docs/src/design/numerics.md).
    pub fn normalized(&self) -> Mesh {
        let (mid, s) = self.normalization();
        let positions =
            self.positions.iter().map(|p| [(p[0] - mid[0]) * s, (p[1] - mid[1]) * s, (p[2] - mid[2]) * s]).collect();
        Mesh { source: self.source.clone(), positions, faces: self.faces.clone() }
    }

    /// The transform of [`Mesh::normalized`]: `p -> (p - mid) * s`.
    ///
    /// Meshes whose areas over- or underflow in the file's units (coordinates beyond about
    /// 1e77 or below 1e-77) get the same transform computed at unit extent; the usual path is
    /// left as it is, so ordinary meshes keep their exact bits. The result is not finite only
    /// when the coordinates span more than an `f64` holds (reported by [`validate()`](super::validate())).
    pub fn normalization(&self) -> ([f64; 3], f64) {
        let (lo, hi) = self.bbox().unwrap_or(([0.0; 3], [0.0; 3]));
        let mut mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
        let total = self.total_area();
        if total.is_normal() && mid.iter().all(|c| c.is_finite()) {
            return (mid, 1.0 / total.sqrt());
        }
        for k in 0..3 {
            if !mid[k].is_finite() {
                // lo + hi overflowed (both near f64::MAX); the half-span does not.
                mid[k] = lo[k] + 0.5 * (hi[k] - lo[k]);
            }
        }
        let k = 1.0 / self.extent();
        let area: f64 = (0..self.n_faces()).map(|f| self.face_area_scaled(f, k)).sum();
        (mid, k / area.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(scale: f64) -> Mesh {
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 2.0, 0.0]];
        Mesh::new("t", positions.iter().map(|p| p.map(|c| c * scale)).collect(), vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn normalization_works_where_areas_over_or_underflow() {
        let usual = square(1.0).normalized();
        assert!((usual.total_area() - 1.0).abs() < 1e-15);
        for scale in [1e300, -1e300, 1e-300, 1e200, 1e-200, 3e307] {
            let m = square(scale);
            assert!(!m.total_area().is_normal(), "{scale}: not an overflow case");
            let n = m.normalized();
            assert!((n.total_area() - 1.0).abs() < 1e-12, "{scale}: area {}", n.total_area());
            for (p, q) in n.positions.iter().zip(&usual.positions) {
                let sign = scale.signum();
                assert!((0..3).all(|k| (p[k] - sign * q[k]).abs() < 1e-12), "{scale}: {p:?} vs {q:?}");
            }
        }
        // both ends near f64::MAX: lo + hi overflows, the half-span does not
        let mut m = square(1e307);
        m.positions.iter_mut().for_each(|p| p[0] += 1.6e308);
        let n = m.normalized();
        assert!((n.total_area() - 1.0).abs() < 1e-12 && n.positions.iter().flatten().all(|c| c.is_finite()));
    }

    #[test]
    fn bbox_diagonal_and_extent_do_not_overflow() {
        assert!((square(1e300).bbox_diagonal() / 1e300 - 5f64.sqrt()).abs() < 1e-15);
        assert!((square(1e-300).bbox_diagonal() / 1e-300 - 5f64.sqrt()).abs() < 1e-15);
        assert_eq!(square(1.0).bbox_diagonal(), 5f64.sqrt());
        assert_eq!(square(1e300).extent(), 2e300);
        assert_eq!(Mesh::new("t", vec![], vec![]).extent(), 0.0);
    }
}
