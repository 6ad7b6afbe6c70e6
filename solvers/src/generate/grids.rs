//! The grids and ring disks the generated shapes are built from: disks of concentric rings
//! on an embedding (a height field, a sphere, a surface of revolution) and planar cell grids.

use std::f64::consts::{PI, TAU};

/// How a ring disk is embedded: point at normalized radius `r` in [0, 1] and angle `phi`,
/// the ratio of the 3D ring circumference to `2 pi` times the meridian length, used to
/// pick how many vertices each ring gets (about equilateral triangles).
pub(super) struct Embedding {
    pub(super) point: Box<dyn Fn(f64, f64) -> [f64; 3]>,
    pub(super) ring_radius: Box<dyn Fn(f64) -> f64>,
}

/// The unit disk lifted by a height field `z = h(x, y)`.
pub(super) fn plane(h: impl Fn(f64, f64) -> f64 + 'static) -> Embedding {
    Embedding {
        point: Box::new(move |r, phi| {
            let (x, y) = (r * phi.cos(), r * phi.sin());
            [x, y, h(x, y)]
        }),
        ring_radius: Box::new(|r| r),
    }
}

/// A spherical cap of the unit sphere around the south pole, of polar angle `theta_max`.
pub(super) fn sphere(theta_max: f64) -> Embedding {
    Embedding {
        point: Box::new(move |r, phi| {
            let th = r * theta_max;
            [th.sin() * phi.cos(), th.sin() * phi.sin(), -th.cos()]
        }),
        ring_radius: Box::new(move |r| (r * theta_max).sin() / theta_max),
    }
}

/// Triangulate a disk with `rings` rings around a centre vertex.
pub(super) fn ring_disk(rings: usize, emb: &Embedding) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let mut positions = vec![(emb.point)(0.0, 0.0)];
    let mut faces = Vec::new();
    // (first index, count, angular offset) of the previous ring
    let mut prev = (0usize, 1usize, 0.0f64);
    for k in 1..=rings {
        let r = k as f64 / rings as f64;
        let n = ((TAU * (emb.ring_radius)(r) * rings as f64).round() as usize).max(6);
        // Stagger consecutive rings by half a step for better-shaped triangles.
        let offset = if k % 2 == 1 { PI / n as f64 } else { 0.0 };
        let first = positions.len();
        for i in 0..n {
            positions.push((emb.point)(r, offset + TAU * i as f64 / n as f64));
        }
        zip_rings(prev, (first, n, offset), &mut faces);
        prev = (first, n, offset);
    }
    (positions, faces)
}

/// Counter-clockwise triangles between an inner and an outer ring, advancing on the ring
/// whose next vertex has the smaller angle. A ring of count 1 is the centre vertex.
pub(super) fn zip_rings(inner: (usize, usize, f64), outer: (usize, usize, f64), faces: &mut Vec<[usize; 3]>) {
    let (a0, na, oa) = inner;
    let (b0, nb, ob) = outer;
    let a = |i: usize| a0 + i % na;
    let b = |j: usize| b0 + j % nb;
    if na == 1 {
        for j in 0..nb {
            faces.push([a0, b(j), b(j + 1)]);
        }
        return;
    }
    let angle_a = |i: usize| oa + TAU * i as f64 / na as f64;
    let angle_b = |j: usize| ob + TAU * j as f64 / nb as f64;
    let (mut i, mut j) = (0, 0);
    while i < na || j < nb {
        let advance_outer = i == na || (j < nb && angle_b(j + 1) <= angle_a(i + 1));
        if advance_outer {
            faces.push([a(i), b(j), b(j + 1)]);
            j += 1;
        } else {
            faces.push([a(i), b(j), a(i + 1)]);
            i += 1;
        }
    }
}

/// A planar (z = 0) mesh of the unit cells `(i, j)` of an `nx x ny` grid kept by `keep`, each
/// split into two counter-clockwise triangles (alternating diagonals), scaled by `h`.
pub(super) fn cells_2d(
    nx: usize,
    ny: usize,
    h: f64,
    keep: impl Fn(usize, usize) -> bool,
) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let mut index = vec![usize::MAX; (nx + 1) * (ny + 1)];
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let mut vid = |i: usize, j: usize, positions: &mut Vec<[f64; 3]>| {
        let k = j * (nx + 1) + i;
        if index[k] == usize::MAX {
            index[k] = positions.len();
            positions.push([i as f64 * h, j as f64 * h, 0.0]);
        }
        index[k]
    };
    for j in 0..ny {
        for i in 0..nx {
            if !keep(i, j) {
                continue;
            }
            let p = vid(i, j, &mut positions);
            let q = vid(i + 1, j, &mut positions);
            let r = vid(i + 1, j + 1, &mut positions);
            let s = vid(i, j + 1, &mut positions);
            if (i + j) % 2 == 0 {
                faces.extend([[p, q, r], [p, r, s]]);
            } else {
                faces.extend([[p, q, s], [q, r, s]]);
            }
        }
    }
    (positions, faces)
}

/// Counter-clockwise (in the `(i, j)` plane) triangles of an `nx x ny` vertex grid, indexed
/// `j * nx + i`, with alternating diagonals.
pub(super) fn grid_faces(nx: usize, ny: usize) -> Vec<[usize; 3]> {
    let id = |i: usize, j: usize| j * nx + i;
    let mut faces = Vec::with_capacity(2 * (nx - 1) * (ny - 1));
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let (p, q, r, s) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                faces.extend([[p, q, r], [p, r, s]]);
            } else {
                faces.extend([[p, q, s], [q, r, s]]);
            }
        }
    }
    faces
}
