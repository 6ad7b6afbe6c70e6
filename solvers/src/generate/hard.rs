//! The hard generated shapes: the geometry that makes real meshes take tens of Newton and
//! hundreds of first-order iterations, which the smooth disk patches of the parent module
//! lack. Each is what the papers use because it is hard:
//!
//! - [`hilbert`]: a planar domain following a Hilbert curve (the CM paper's `hilbert`): thin
//!   corridors that the Tutte map folds into a disk, so the solver has to unroll them.
//! - [`bumpy_torus_cut`]: a bumpy torus cut along a meridian and a longitude into a square
//!   (complex-view paper, Figure 2): curvature of both signs and a boundary with 4 corners.
//! - [`finger`]: a long closed tube rising from a flat brim (a glove finger): Tutte shrinks
//!   the tube's rings geometrically towards the tip.
//! - [`with_slivers`]: a triangulation with inserted near-degenerate faces (scans have angles
//!   down to 0.005 degrees).
//!
//! Everything is deterministic: no RNG state, only a fixed integer hash of the face index.

use super::grids::{cells_2d, grid_faces, ring_disk, Embedding};
use std::f64::consts::{FRAC_PI_2, TAU};

type Shape = (Vec<[f64; 3]>, Vec<[usize; 3]>);

/// Cell `(x, y)` of the `2^order x 2^order` grid at position `d` along the Hilbert curve
/// (the classic iterative `d2xy`: rotate and reflect the quadrant at each level).
pub(super) fn hilbert_cell(order: u32, d: usize) -> (usize, usize) {
    let (mut x, mut y, mut t) = (0usize, 0usize, d);
    let mut s = 1usize;
    while s < (1 << order) {
        let rx = 1 & (t / 2);
        let ry = 1 & (t ^ rx);
        if ry == 0 {
            if rx == 1 {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        x += s * rx;
        y += s * ry;
        t /= 4;
        s *= 2;
    }
    (x, y)
}

/// The planar domain of a Hilbert curve of the given order: on a macro grid of
/// `2^(order+1) - 1` cells per side, the curve's cells sit at even coordinates and the links
/// between consecutive ones at the odd cell between them, so corridors and walls are one
/// macro cell wide. Each macro cell is `m x m` grid cells. Every grid corner has the
/// (even, even) macro cell of its four kept, so no two kept cells meet at a corner only: the
/// domain is a manifold disk (the curve is a path).
pub(super) fn hilbert(order: u32, m: usize) -> Shape {
    let side = (1usize << (order + 1)) - 1;
    let mut kept = vec![false; side * side];
    let mut prev: Option<(usize, usize)> = None;
    for d in 0..(1usize << (2 * order)) {
        let (x, y) = hilbert_cell(order, d);
        kept[2 * y * side + 2 * x] = true;
        if let Some((px, py)) = prev {
            kept[(y + py) * side + (x + px)] = true; // the link: midpoint of the two cells
        }
        prev = Some((x, y));
    }
    cells_2d(side * m, side * m, 1.0 / m as f64, |i, j| kept[(j / m) * side + i / m])
}

/// A torus of radii `R = 1`, `r = 0.42` with periodic bumps on the tube radius, cut along
/// the meridian `u = 0` and the longitude `v = 0` into an `nu x nv` grid (alternating
/// diagonals). The seam vertices are duplicated: the cut mesh is a disk whose boundary runs
/// twice along each cut.
pub(super) fn bumpy_torus_cut(nu: usize, nv: usize, r0: f64, b1: f64, b2: f64) -> Shape {
    let point = |u: f64, v: f64| {
        let r = r0 * (1.0 + b1 * (3.0 * u).sin() * (2.0 * v).cos() + b2 * (7.0 * u + 1.0).cos() * v.sin());
        let ring = 1.0 + r * v.cos();
        [ring * u.cos(), ring * u.sin(), r * v.sin()]
    };
    let mut positions = Vec::with_capacity((nu + 1) * (nv + 1));
    for j in 0..=nv {
        for i in 0..=nu {
            positions.push(point(TAU * i as f64 / nu as f64, TAU * j as f64 / nv as f64));
        }
    }
    (positions, grid_faces(nu + 1, nv + 1))
}

/// A glove finger: a tube of radius `a` and straight length `len` closed by a hemisphere at
/// its tip, joined by a quarter-circle fillet of radius `fillet` to a flat brim out to radius
/// `brim`, whose rim is the boundary. A surface of revolution about the z axis, meshed ring by
/// ring from the tip with `rings` rings evenly spaced in arc length.
pub(super) fn finger(rings: usize, a: f64, len: f64, fillet: f64, brim: f64) -> Shape {
    // Profile (rho, z) by arc length s from the tip, piece by piece.
    let (s_tip, s_tube, s_fillet) = (FRAC_PI_2 * a, len, FRAC_PI_2 * fillet);
    let s_brim = brim - a - fillet;
    let total = s_tip + s_tube + s_fillet + s_brim;
    let profile = move |s: f64| -> (f64, f64) {
        if s <= s_tip {
            let t = s / a;
            (a * t.sin(), -a * t.cos())
        } else if s <= s_tip + s_tube {
            (a, s - s_tip)
        } else if s <= s_tip + s_tube + s_fillet {
            // centre of the fillet at (a + fillet, len); the profile turns from up to outwards
            let t = (s - s_tip - s_tube) / fillet;
            (a + fillet - fillet * t.cos(), len + fillet * t.sin())
        } else {
            (a + fillet + (s - s_tip - s_tube - s_fillet), len + fillet)
        }
    };
    let emb = Embedding {
        point: Box::new(move |r, phi| {
            let (rho, z) = profile(r * total);
            [rho * phi.cos(), rho * phi.sin(), z]
        }),
        ring_radius: Box::new(move |r| profile(r * total).0 / total),
    };
    ring_disk(rings, &emb)
}

/// splitmix64: a fixed integer hash (the generator's only "randomness"; the same bits on
/// every platform and every version, unlike an RNG crate's streams).
fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Uniform in [0, 1) from the hash of `(seed, key, slot)`.
fn unit(seed: u64, key: usize, slot: u64) -> f64 {
    (splitmix(seed ^ splitmix((key as u64) << 3 | slot)) >> 11) as f64 / (1u64 << 53) as f64
}

/// `base` with about one face in `every` split by a new vertex `p` placed very close to one
/// of its edges `(a, b)`: `p = (1 - d) (a + l (b - a)) + d c` with `l` in [0.3, 0.7] and the
/// relative height `d` log-uniform in [`d_min`, `d_max`]. The face `(a, b, c)` becomes
/// `(a, b, p)` (a cap sliver: angles about `d / l` at `a` and `b`), `(b, c, p)` and
/// `(c, a, p)`; orientation and manifoldness are kept, Euler characteristic unchanged.
/// Which faces, which edge, `l` and `d` come from the hash of `seed` and the face index.
pub(super) fn with_slivers(base: Shape, every: u64, d_min: f64, d_max: f64, seed: u64) -> Shape {
    let (mut positions, old) = base;
    let mut faces = Vec::with_capacity(old.len() + old.len() / every as usize * 2 + 2);
    for (t, f) in old.into_iter().enumerate() {
        if !splitmix(seed ^ t as u64).is_multiple_of(every) {
            faces.push(f);
            continue;
        }
        let k = (unit(seed, t, 0) * 3.0) as usize % 3;
        let [a, b, c] = [f[k], f[(k + 1) % 3], f[(k + 2) % 3]];
        let l = 0.3 + 0.4 * unit(seed, t, 1);
        let d = d_min * (d_max / d_min).powf(unit(seed, t, 2));
        let (pa, pb, pc) = (positions[a], positions[b], positions[c]);
        let p: [f64; 3] = std::array::from_fn(|i| (1.0 - d) * (pa[i] + l * (pb[i] - pa[i])) + d * pc[i]);
        let v = positions.len();
        positions.push(p);
        faces.extend([[a, b, v], [b, c, v], [c, a, v]]);
    }
    (positions, faces)
}

/// Smallest interior angle of any face, in degrees (3D).
#[cfg(test)]
pub(super) fn min_angle_deg(positions: &[[f64; 3]], faces: &[[usize; 3]]) -> f64 {
    let mut min_angle = f64::INFINITY;
    for f in faces {
        let p = f.map(|v| positions[v]);
        for k in 0..3 {
            let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            let u: [f64; 3] = std::array::from_fn(|i| b[i] - a[i]);
            let v: [f64; 3] = std::array::from_fn(|i| c[i] - a[i]);
            let cross = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let cos = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
            // atan2 stays accurate for tiny angles, where acos of the cosine does not
            min_angle = min_angle.min(sin.atan2(cos).to_degrees());
        }
    }
    min_angle
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{validate, Mesh};
    use std::f64::consts::PI;

    fn valid_disk(name: &str, (positions, faces): Shape) -> Mesh {
        let mesh = Mesh::new(name, positions, faces);
        let report = validate(&mesh, true);
        assert!(report.is_ok(), "{report}");
        assert_eq!((report.boundary_loops, report.euler, report.components), (1, 1, 1), "{name}");
        mesh
    }

    #[test]
    fn the_hilbert_curve_visits_every_cell_once_through_neighbours() {
        assert_eq!((0..4).map(|d| hilbert_cell(1, d)).collect::<Vec<_>>(), [(0, 0), (0, 1), (1, 1), (1, 0)]);
        for order in 1..=5 {
            let n = 1usize << order;
            let cells: Vec<_> = (0..n * n).map(|d| hilbert_cell(order, d)).collect();
            let mut seen = vec![false; n * n];
            for &(x, y) in &cells {
                assert!(x < n && y < n && !seen[y * n + x], "order {order}: ({x}, {y})");
                seen[y * n + x] = true;
            }
            for w in cells.windows(2) {
                assert_eq!(w[0].0.abs_diff(w[1].0) + w[0].1.abs_diff(w[1].1), 1, "order {order}: {w:?}");
            }
            // it starts and ends at the two bottom corners, like the CM paper's domain
            assert_eq!((cells[0], cells[n * n - 1]), ((0, 0), (n - 1, 0)));
        }
    }

    #[test]
    fn the_hilbert_domain_is_a_planar_disk_of_corridors() {
        for (order, m) in [(3, 4), (4, 2)] {
            let mesh = valid_disk("hilbert", hilbert(order, m));
            assert!(mesh.is_planar());
            // 4^order curve cells and 4^order - 1 links, each m x m grid cells of two triangles
            let macro_cells = 2 * (1usize << (2 * order)) - 1;
            assert_eq!(mesh.n_faces(), 2 * m * m * macro_cells);
            // each cell has area (1/m)^2: the domain's area is the number of macro cells
            assert!((mesh.total_area() - macro_cells as f64).abs() < 1e-9);
            // the boundary is long: the corridors' walls, not the bounding square's perimeter
            let boundary = crate::mesh::topology::boundary_loops(&mesh.faces, mesh.n_vertices());
            let len: f64 = boundary[0]
                .iter()
                .zip(boundary[0].iter().cycle().skip(1))
                .map(|(&a, &b)| {
                    let (p, q) = (mesh.positions[a], mesh.positions[b]);
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
                })
                .sum();
            assert!((len - (2.0 * macro_cells as f64 + 2.0)).abs() < 1e-9, "order {order}: boundary {len}");
            for f in &mesh.faces {
                assert!(crate::local::signed_area(f.map(|v| [mesh.positions[v][0], mesh.positions[v][1]])) > 0.0);
            }
        }
    }

    #[test]
    fn the_cut_torus_is_a_disk_whose_seams_close_in_space() {
        let (nu, nv) = (24, 10);
        let mesh = valid_disk("torus", bumpy_torus_cut(nu, nv, 0.42, 0.22, 0.12));
        assert_eq!((mesh.n_vertices(), mesh.n_faces()), ((nu + 1) * (nv + 1), 2 * nu * nv));
        let at = |i: usize, j: usize| mesh.positions[j * (nu + 1) + i];
        let close = |p: [f64; 3], q: [f64; 3]| (0..3).all(|k| (p[k] - q[k]).abs() < 1e-12);
        // the two copies of each cut coincide: glued back, it is the closed torus
        assert!((0..=nv).all(|j| close(at(0, j), at(nu, j))));
        assert!((0..=nu).all(|i| close(at(i, 0), at(i, nv))));
        // a torus of major radius 1: every point lies within the tube's reach of the unit circle
        for p in &mesh.positions {
            let d = (((p[0] * p[0] + p[1] * p[1]).sqrt() - 1.0).powi(2) + p[2] * p[2]).sqrt();
            assert!(d > 0.42 * (1.0 - 0.34) - 1e-12 && d < 0.42 * (1.0 + 0.34) + 1e-12, "{p:?}");
        }
    }

    #[test]
    fn the_finger_is_a_deep_tube_on_a_flat_brim() {
        let (a, len, fillet, brim) = (0.15, 1.2, 0.1, 1.0);
        let mesh = valid_disk("finger", finger(36, a, len, fillet, brim));
        let z = |v: usize| mesh.positions[v][2];
        let rho = |v: usize| mesh.positions[v][0].hypot(mesh.positions[v][1]);
        let (zmin, zmax) = (0..mesh.n_vertices()).map(z).fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)));
        // tip at z = -a, brim at z = len + fillet
        assert!((zmin + a).abs() < 1e-12 && (zmax - (len + fillet)).abs() < 1e-12, "{zmin} {zmax}");
        // the boundary is the brim's rim
        let boundary = crate::mesh::topology::boundary_loops(&mesh.faces, mesh.n_vertices());
        assert!(boundary[0].iter().all(|&v| (rho(v) - brim).abs() < 1e-12 && (z(v) - zmax).abs() < 1e-12));
        // the tube: every vertex strictly between tip and fillet lies on the cylinder of radius a
        let tube: Vec<usize> = (0..mesh.n_vertices()).filter(|&v| z(v) > 1e-9 && z(v) < len - 1e-9).collect();
        assert!(tube.len() > mesh.n_vertices() / 5, "{} of {}", tube.len(), mesh.n_vertices());
        assert!(tube.iter().all(|&v| (rho(v) - a).abs() < 1e-12));
        // area: hemisphere + cylinder + brim annulus, plus the fillet (between its bounds)
        let known = 2.0 * PI * a * a + 2.0 * PI * a * len + PI * (brim * brim - (a + fillet).powi(2));
        let fillet_max = 2.0 * PI * (a + fillet) * FRAC_PI_2 * fillet;
        let area = mesh.total_area();
        assert!(area < known + fillet_max && area > 0.9 * known, "{area} vs {known}");
    }

    #[test]
    fn slivers_split_faces_into_near_degenerate_ones_the_validator_accepts() {
        let base = hilbert(2, 3);
        let (n0, f0) = (base.0.len(), base.1.len());
        let shape = with_slivers(base.clone(), 4, 5e-5, 1e-2, 19);
        assert_eq!(shape, with_slivers(base.clone(), 4, 5e-5, 1e-2, 19), "deterministic");
        assert_ne!(shape, with_slivers(base.clone(), 4, 5e-5, 1e-2, 20), "the seed matters");
        let inserted = shape.0.len() - n0;
        // one new vertex and two more faces per split face; about one face in 4 split
        assert_eq!(shape.1.len(), f0 + 2 * inserted);
        assert!((inserted as f64 / f0 as f64 - 0.25).abs() < 0.05, "{inserted} of {f0}");
        // a cap sliver has angles about d / l at the edge's ends: d >= 5e-5, l <= 0.7 on a
        // right isosceles grid triangle (height over the edge at least 0.5 of it)
        let min = min_angle_deg(&shape.0, &shape.1);
        assert!(min > 0.001 && min < 0.01, "min angle {min} degrees");
        assert!(min_angle_deg(&base.0, &base.1) > 40.0);
        let mesh = valid_disk("slivers", shape);
        for f in &mesh.faces {
            assert!(crate::local::signed_area(f.map(|v| [mesh.positions[v][0], mesh.positions[v][1]])) > 0.0);
        }
    }
}
