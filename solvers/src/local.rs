//! Per-triangle local operators in the complex view (complex-view paper, Section 3.2).
//!
//! Each source triangle is placed in the plane (an isometric flattening of a 3D triangle,
//! or the triangle itself for planar input) with vertices `z_1, z_2, z_3`. With the edges
//! `e_1 = z_2 - z_3`, `e_2 = z_3 - z_1`, `e_3 = z_1 - z_2` and the area `A`, the operator
//! `D = i/(4A) conj(e)` gives the Wirtinger derivatives of the linear map with target
//! vertices `Y`: `f_z = D Y`, `f_zbar = conj(D) Y`.

use crate::mesh::Mesh;
use nalgebra::{Matrix4x6, Vector4, Vector6};

/// The local operator of one triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalOp {
    /// Source area (positive).
    pub area: f64,
    /// Real parts of the three complex coefficients `D_k`.
    pub d_re: [f64; 3],
    /// Imaginary parts of the `D_k` (`d_re` holds the real parts).
    pub d_im: [f64; 3],
}

/// Wirtinger derivatives of the linear map of one triangle, as real 2-vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wirtinger {
    /// `f_z` as `[re, im]`.
    pub fz: [f64; 2],
    /// `f_zbar` as `[re, im]`.
    pub fzb: [f64; 2],
}

impl Wirtinger {
    /// `x = |f_z|^2`
    #[inline]
    pub fn x(&self) -> f64 {
        self.fz[0] * self.fz[0] + self.fz[1] * self.fz[1]
    }
    /// `y = |f_zbar|^2`
    #[inline]
    pub fn y(&self) -> f64 {
        self.fzb[0] * self.fzb[0] + self.fzb[1] * self.fzb[1]
    }
    /// The signed singular values `(sigma1, sigma2) = (|f_z| + |f_zbar|, |f_z| - |f_zbar|)` of
    /// the Jacobian: `sigma2 < 0` when the map reverses orientation.
    #[inline]
    pub fn singular_values(&self) -> [f64; 2] {
        let (a, b) = (self.x().sqrt(), self.y().sqrt());
        [a + b, a - b]
    }
    /// The stacked 4-vector `(f_z, f_zbar)`.
    #[inline]
    pub fn stacked(&self) -> Vector4<f64> {
        Vector4::new(self.fz[0], self.fz[1], self.fzb[0], self.fzb[1])
    }
}

impl LocalOp {
    /// Build the operator from the three planar source vertices (counter-clockwise).
    /// Returns `None` for a degenerate or clockwise triangle.
    pub fn from_planar(z: [[f64; 2]; 3]) -> Option<LocalOp> {
        let e = [
            [z[1][0] - z[2][0], z[1][1] - z[2][1]],
            [z[2][0] - z[0][0], z[2][1] - z[0][1]],
            [z[0][0] - z[1][0], z[0][1] - z[1][1]],
        ];
        // signed area = cross(z2 - z1, z3 - z1) / 2 = cross(-e3, e2) / 2
        let area = 0.5 * ((-e[2][0]) * e[1][1] - (-e[2][1]) * e[1][0]);
        if !(area > 0.0) || !area.is_finite() {
            return None;
        }
        // D_k = i/(4A) * conj(e_k) = i/(4A) (er - i ei) = (ei + i er) / (4A)
        let c = 1.0 / (4.0 * area);
        let mut d_re = [0.0; 3];
        let mut d_im = [0.0; 3];
        for k in 0..3 {
            d_re[k] = e[k][1] * c;
            d_im[k] = e[k][0] * c;
        }
        Some(LocalOp { area, d_re, d_im })
    }

    /// The operator of a 3D triangle in its [`flatten`]ed frame.
    pub fn from_3d(p: [[f64; 3]; 3]) -> Option<LocalOp> {
        let z = flatten(p);
        if !(z[1][0] > 0.0) {
            return None;
        }
        LocalOp::from_planar(z)
    }

    /// Wirtinger derivatives of the map with target vertex positions `y` (u, v per vertex).
    #[inline]
    pub fn wirtinger(&self, y: [[f64; 2]; 3]) -> Wirtinger {
        let mut fz = [0.0; 2];
        let mut fzb = [0.0; 2];
        for (k, &[u, v]) in y.iter().enumerate() {
            let (dr, di) = (self.d_re[k], self.d_im[k]);
            // D_k (u + iv)
            fz[0] += dr * u - di * v;
            fz[1] += di * u + dr * v;
            // conj(D_k) (u + iv)
            fzb[0] += dr * u + di * v;
            fzb[1] += -di * u + dr * v;
        }
        Wirtinger { fz, fzb }
    }

    /// The real 4x6 matrix `M = [D; conj D]` mapping the local dofs
    /// `(u_1, v_1, u_2, v_2, u_3, v_3)` to `(Re f_z, Im f_z, Re f_zbar, Im f_zbar)` (Eq. 2).
    pub fn m(&self) -> Matrix4x6<f64> {
        let mut m = Matrix4x6::zeros();
        for k in 0..3 {
            let (dr, di) = (self.d_re[k], self.d_im[k]);
            m[(0, 2 * k)] = dr;
            m[(1, 2 * k)] = di;
            m[(2, 2 * k)] = dr;
            m[(3, 2 * k)] = -di;
            m[(0, 2 * k + 1)] = -di;
            m[(1, 2 * k + 1)] = dr;
            m[(2, 2 * k + 1)] = di;
            m[(3, 2 * k + 1)] = dr;
        }
        m
    }

    /// `M^T w` for a 4-vector `w` without forming `M`: per vertex, the two columns of
    /// [`LocalOp::m`] dotted with `w`, summed in the order of the product `M^T w`
    /// (`mt_times_is_the_matrix_product`: the same bits), on every evaluation's path.
    #[inline]
    pub fn mt_times(&self, w: Vector4<f64>) -> Vector6<f64> {
        let mut out = Vector6::zeros();
        for k in 0..3 {
            let (dr, di) = (self.d_re[k], self.d_im[k]);
            out[2 * k] = dr * w[0] + di * w[1] + dr * w[2] + -di * w[3];
            out[2 * k + 1] = -di * w[0] + dr * w[1] + di * w[2] + dr * w[3];
        }
        out
    }
}

/// Isometric flattening of a 3D triangle from its edge lengths: vertex 1 at 0, vertex 2 on
/// the positive real axis, vertex 3 in the upper half plane, as the reference code does (NaN
/// for a zero first edge).
pub fn flatten(p: [[f64; 3]; 3]) -> [[f64; 2]; 3] {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let u = sub(p[1], p[0]);
    let v = sub(p[2], p[0]);
    let lu = dot(u, u).sqrt();
    // coordinates of v in the frame (u/|u|, n x u/|u|): x = <u,v>/|u|, y = |u x v|/|u|
    let cx = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let vx = dot(u, v) / lu;
    let vy = dot(cx, cx).sqrt() / lu;
    [[0.0, 0.0], [lu, 0.0], [vx, vy]]
}

/// Local operators of every face of a mesh: planar meshes use their own coordinates (so
/// the identity is the rest pose of a deformation), 3D meshes are flattened per triangle.
/// A planar face that is clockwise in the xy-plane is the surface seen from below: it uses
/// the plane reflected (`y -> -y`), which is just as isometric, so a `param` input does not
/// fail for the side it was drawn from (`deform` refuses clockwise rest poses before this).
/// Returns the index of the first degenerate face on failure.
pub fn local_ops(mesh: &Mesh) -> Result<Vec<LocalOp>, usize> {
    let planar = mesh.is_planar();
    mesh.faces
        .iter()
        .enumerate()
        .map(|(t, f)| {
            let p = [mesh.positions[f[0]], mesh.positions[f[1]], mesh.positions[f[2]]];
            let op = if planar {
                let z = [[p[0][0], p[0][1]], [p[1][0], p[1][1]], [p[2][0], p[2][1]]];
                LocalOp::from_planar(z).or_else(|| LocalOp::from_planar(z.map(|[x, y]| [x, -y])))
            } else {
                LocalOp::from_3d(p)
            };
            op.ok_or(t)
        })
        .collect()
}

/// Signed area of a target triangle (defined beside the mesh, whose validation needs it).
pub use crate::mesh::signed_area;

#[cfg(test)]
mod tests {
    use super::*;

    fn op_unit() -> LocalOp {
        LocalOp::from_planar([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).unwrap()
    }

    /// The hand-written `M^T w` gives the bits of nalgebra's product with `M`'s transpose.
    #[test]
    fn mt_times_is_the_matrix_product() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut r = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        for _ in 0..1000 {
            let Some(op) = LocalOp::from_planar([[r(), r()], [r(), r()], [r(), r()]]) else { continue };
            let w = Vector4::new(r(), r(), r(), r()) * 10f64.powf(r() * 3.0);
            let want = op.m().transpose() * w;
            let got = op.mt_times(w);
            assert_eq!(want.map(f64::to_bits), got.map(f64::to_bits), "{want} vs {got}");
        }
    }

    #[test]
    fn identity_map_has_fz_one_fzbar_zero() {
        let z = [[0.3, -0.2], [1.4, 0.1], [0.2, 0.9]];
        let op = LocalOp::from_planar(z).unwrap();
        let w = op.wirtinger(z);
        assert!((w.fz[0] - 1.0).abs() < 1e-14 && w.fz[1].abs() < 1e-14);
        assert!(w.fzb[0].abs() < 1e-14 && w.fzb[1].abs() < 1e-14);
    }

    #[test]
    fn reflection_is_antiholomorphic() {
        let z = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let op = op_unit();
        // f(z) = conj(z): (u, v) -> (u, -v)
        let y = z.map(|p| [p[0], -p[1]]);
        let w = op.wirtinger(y);
        assert!(w.fz[0].abs() < 1e-14 && w.fz[1].abs() < 1e-14);
        assert!((w.fzb[0] - 1.0).abs() < 1e-14 && w.fzb[1].abs() < 1e-14);
    }

    #[test]
    fn det_and_frobenius_identities() {
        // |J| = x - y and ||J||_F^2 = 2 (x + y) for an arbitrary linear map
        let op = op_unit();
        let (a, b, c, d) = (1.3, -0.4, 0.7, 2.1); // J = [[a, b], [c, d]]
        let y = [[0.0, 0.0], [a, c], [b, d]];
        let w = op.wirtinger(y);
        assert!(((w.x() - w.y()) - (a * d - b * c)).abs() < 1e-13);
        assert!((2.0 * (w.x() + w.y()) - (a * a + b * b + c * c + d * d)).abs() < 1e-13);
        assert!(((a * d - b * c) - 2.0 * signed_area(y)).abs() < 1e-13);
    }

    #[test]
    fn singular_values_match_the_svd() {
        // (a, b, c, d) of J = [[a, b], [c, d]]: a generic map, a stretch, a scaled rotation and
        // a reflection (negative sigma2)
        let (c, s) = (0.7f64.cos(), 0.7f64.sin());
        let maps =
            [(1.3, -0.4, 0.7, 2.1), (2.0, 0.0, 0.0, 1.0), (3.0 * c, -3.0 * s, 3.0 * s, 3.0 * c), (1.0, 0.0, 0.0, -1.0)];
        let op = op_unit();
        for (a, b, c, d) in maps {
            let [s1, s2] = op.wirtinger([[0.0, 0.0], [a, c], [b, d]]).singular_values();
            let sv = nalgebra::Matrix2::new(a, b, c, d).singular_values();
            assert!((s1 - sv.max()).abs() < 1e-13 && (s2.abs() - sv.min()).abs() < 1e-13, "{s1} {s2} {sv}");
            assert!((s1 * s2 - (a * d - b * c)).abs() < 1e-13, "sigma1 sigma2 = det J");
        }
    }

    #[test]
    fn flattening_preserves_lengths_and_area() {
        let p = [[0.1, 0.2, 0.3], [1.0, -0.5, 0.7], [0.4, 0.9, -0.2]];
        let op = LocalOp::from_3d(p).unwrap();
        let mesh = Mesh::new("t", p.to_vec(), vec![[0, 1, 2]]);
        assert!((op.area - mesh.face_area(0)).abs() < 1e-14);
        let z = flatten(p);
        assert!((signed_area(z) - op.area).abs() < 1e-14);
        let len =
            |a: [f64; 3], b: [f64; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let len2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            assert!((len(p[i], p[j]) - len2(z[i], z[j])).abs() < 1e-14);
        }
    }

    #[test]
    fn m_matches_wirtinger() {
        let op = LocalOp::from_planar([[0.1, 0.0], [1.2, 0.3], [0.4, 1.1]]).unwrap();
        let y = [[0.3, 0.5], [-0.2, 1.7], [1.1, 0.4]];
        let w = op.wirtinger(y);
        let yv = Vector6::new(y[0][0], y[0][1], y[1][0], y[1][1], y[2][0], y[2][1]);
        let s = op.m() * yv;
        assert!((s - w.stacked()).norm() < 1e-14);
    }

    #[test]
    fn clockwise_planar_faces_get_the_reflected_frame() {
        // a planar square drawn clockwise (seen from below), at z = 5 like a lifted 2D shape
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 2.0, 0.0]];
        let ccw = Mesh::new("t", positions, vec![[0, 1, 2], [0, 2, 3]]);
        let mut cw = ccw.clone();
        cw.faces.iter_mut().for_each(|f| f.swap(1, 2));
        let (a, b) = (local_ops(&ccw).unwrap(), local_ops(&cw.normalized()).unwrap());
        assert!(b.iter().all(|o| o.area > 0.0));
        // same metric: the identity of the counter-clockwise copy and the reflection y -> -y of
        // the clockwise one both have f_z = 1, f_zbar = 0 (the mirror image as seen from below)
        let rest = cw.normalized();
        for (t, op) in b.iter().enumerate() {
            let y = rest.faces[t].map(|v| [rest.positions[v][0], -rest.positions[v][1]]);
            let w = op.wirtinger(y);
            assert!((w.fz[0] - 1.0).abs() < 1e-14 && w.fz[1].abs() < 1e-14 && w.y() < 1e-28, "{w:?}");
        }
        // counter-clockwise faces keep the plain xy frame, bit for bit
        let p = |v: usize| [ccw.positions[v][0], ccw.positions[v][1]];
        assert_eq!(a[0], LocalOp::from_planar([p(0), p(1), p(2)]).unwrap());
        // a degenerate face is degenerate in either orientation
        let flat = Mesh::new("t", vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], vec![[0, 2, 1]]);
        assert_eq!(local_ops(&flat), Err(0));
    }

    #[test]
    fn degenerate_triangles_are_rejected() {
        assert!(LocalOp::from_planar([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]).is_none());
        assert!(LocalOp::from_planar([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]).is_none());
        assert!(LocalOp::from_3d([[0.0; 3], [0.0; 3], [1.0, 0.0, 0.0]]).is_none());
    }
}
