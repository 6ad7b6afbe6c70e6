//! Initialization for `param`: Tutte's embedding (Floater 1997 with uniform weights) and the
//! global-scaling heuristic of the complex-view paper, Section 4.2.

use crate::energy::EnergyKind;
use crate::hessian::ElementState;
use crate::linear::{LinearError, LinearSettings, SpdSolver};
use crate::mesh::topology::{boundary_loops, vertex_neighbors};
use crate::mesh::Mesh;
use crate::problem::MapProblem;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Placement of the boundary loop on the circle of radius `sqrt(1/pi)` (area 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TutteBoundary {
    /// Equal angles, as the complex-view reference code (`floater97.m`).
    #[default]
    Uniform,
    /// Angles proportional to 3D boundary arc length, as libigl/SLIM/AKVF.
    Arclength,
}

/// Why Tutte's embedding could not be built.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum InitError {
    /// The mesh does not have exactly one boundary loop (the count it has).
    #[error("the mesh has {0} boundary loops; Tutte's embedding needs exactly one")]
    BoundaryLoops(usize),
    /// The boundary loop has fewer than 3 vertices (the count it has).
    #[error("the boundary loop has only {0} vertices (at least 3 needed)")]
    ShortBoundary(usize),
    /// An interior vertex (this one) belongs to no proper face.
    #[error("interior vertex {0} has no neighbours")]
    IsolatedVertex(usize),
    /// The linear solver failed on the interior Laplacian system.
    #[error("the Tutte system could not be solved: {0}")]
    Linear(#[from] LinearError),
    /// The embedding has this many triangles with non-positive signed area.
    #[error("the Tutte embedding flips {0} triangles (non-convex boundary or bad input)")]
    Flipped(usize),
}

/// Tutte's embedding of a disk-topology mesh: uniform graph Laplacian, boundary on the
/// circle of area 1 in the faces' orientation, so the map preserves orientation.
/// Returns the interleaved map `[u0, v0, u1, v1, ...]`.
pub fn tutte(mesh: &Mesh, boundary: TutteBoundary) -> Result<Vec<f64>, InitError> {
    let n = mesh.n_vertices();
    let loops = boundary_loops(&mesh.faces, n);
    if loops.len() != 1 {
        return Err(InitError::BoundaryLoops(loops.len()));
    }
    let bl = &loops[0];
    let nb = bl.len();
    if nb < 3 {
        return Err(InitError::ShortBoundary(nb));
    }
    let mut x = vec![0.0; 2 * n];
    let is_boundary = place_boundary(&mut x, bl, &loop_parameters(mesh, bl, boundary));
    // Interior system L_II x_I = -L_IB x_B with the uniform Laplacian (SPD).
    let nbrs = vertex_neighbors(&mesh.faces, n);
    let mut index = vec![usize::MAX; n];
    let interior: Vec<usize> = (0..n).filter(|&v| !is_boundary[v]).collect();
    for (i, &v) in interior.iter().enumerate() {
        index[v] = i;
    }
    let ni = interior.len();
    if ni == 0 {
        return Ok(x);
    }
    let mut col_ptr = vec![0usize];
    let mut row_idx = Vec::new();
    let mut vals = Vec::new();
    let mut diag = Vec::with_capacity(ni);
    let mut rhs_u = vec![0.0; ni];
    let mut rhs_v = vec![0.0; ni];
    for (i, &v) in interior.iter().enumerate() {
        let deg = nbrs[v].len();
        if deg == 0 {
            return Err(InitError::IsolatedVertex(v));
        }
        let mut lower: Vec<usize> = Vec::new();
        for &w in &nbrs[v] {
            if is_boundary[w] {
                rhs_u[i] += x[2 * w];
                rhs_v[i] += x[2 * w + 1];
            } else if index[w] > i {
                lower.push(index[w]);
            }
        }
        lower.sort_unstable();
        diag.push(row_idx.len());
        row_idx.push(i);
        vals.push(deg as f64);
        for j in lower {
            row_idx.push(j);
            vals.push(-1.0);
        }
        col_ptr.push(row_idx.len());
    }
    // AMD, not METIS: one factorization does not pay back METIS's slower analysis, although
    // METIS's factor is sparser.
    let mut solver = SpdSolver::from_csc(ni, col_ptr, row_idx, diag)?;
    let exact = LinearSettings { tikhonov: 0.0, jacobi: false, ordering: crate::linear::ordering::Ordering::Amd };
    // One factorization, both coordinates as the two columns of one solve.
    solver.factorize(&vals, &exact)?;
    let mut uv = rhs_u;
    uv.extend_from_slice(&rhs_v);
    solver.solve_columns_in_place(&mut uv)?;
    let (u, v) = uv.split_at(ni);
    for (i, &vert) in interior.iter().enumerate() {
        x[2 * vert] = u[i];
        x[2 * vert + 1] = v[i];
    }
    let flipped = flipped_faces(mesh, &x);
    if flipped > 0 {
        return Err(InitError::Flipped(flipped));
    }
    Ok(x)
}

/// The loop `bl`'s vertices on the circle of area 1 at their parameters `params` (in the
/// interleaved map `x`); which vertices are on it.
fn place_boundary(x: &mut [f64], bl: &[usize], params: &[f64]) -> Vec<bool> {
    let mut is_boundary = vec![false; x.len() / 2];
    let r = (1.0 / std::f64::consts::PI).sqrt();
    for (k, &v) in bl.iter().enumerate() {
        let th = 2.0 * std::f64::consts::PI * params[k];
        x[2 * v] = r * th.cos();
        x[2 * v + 1] = r * th.sin();
        is_boundary[v] = true;
    }
    is_boundary
}

/// Each boundary vertex's parameter along the loop `bl`, in `[0, 1)`: uniform or by arc
/// length.
fn loop_parameters(mesh: &Mesh, bl: &[usize], boundary: TutteBoundary) -> Vec<f64> {
    let nb = bl.len();
    match boundary {
        TutteBoundary::Uniform => (0..nb).map(|k| k as f64 / nb as f64).collect(),
        TutteBoundary::Arclength => {
            let len = |a: usize, b: usize| {
                let (p, q) = (mesh.positions[a], mesh.positions[b]);
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
            };
            let mut acc = vec![0.0; nb];
            for k in 1..nb {
                acc[k] = acc[k - 1] + len(bl[k - 1], bl[k]);
            }
            let total = acc[nb - 1] + len(bl[nb - 1], bl[0]);
            acc.iter().map(|a| a / total).collect()
        }
    }
}

/// The faces of `mesh` that the map `x` inverts or collapses.
fn flipped_faces(mesh: &Mesh, x: &[f64]) -> usize {
    (0..mesh.n_faces())
        .filter(|&t| {
            let f = mesh.faces[t];
            let p = f.map(|k| [x[2 * k], x[2 * k + 1]]);
            crate::local::signed_area(p) <= 0.0
        })
        .count()
}

/// Smallest factor `s` that makes the element's `K` PSD when the map is scaled by `s`, for
/// the energies where only `2 a1` can be negative (Section 4.2); `None` for the others.
pub fn element_psd_scale(energy: &EnergyKind, s: &ElementState) -> Option<f64> {
    energy.psd_scale(s.x(), s.y())
}

/// The global scale of Section 4.2: sort the per-element PSD scales, walk from the middle of
/// the sorted sequence and take the first scale whose difference to the previous one
/// exceeds `jump` (absolute; meshes have area 1); without such a jump take the maximum,
/// the smallest scale that makes every element PSD. `None` for energies without the rule.
pub fn global_scale(problem: &MapProblem, x: &[f64], jump: f64) -> Option<f64> {
    let energy = problem.energy;
    let mut scales: Vec<f64> = (0..problem.n_faces())
        .into_par_iter()
        .map(|t| {
            let w = problem.ops[t].wirtinger(problem.target(x, t));
            let m = energy.modifiers(w.x(), w.y()).unwrap_or_default();
            element_psd_scale(&energy, &ElementState::new(w, m)).unwrap_or(f64::NAN)
        })
        .collect();
    if scales.is_empty() || scales.iter().any(|s| !s.is_finite()) {
        return None;
    }
    scales.sort_by(f64::total_cmp);
    let nf = scales.len();
    let start = nf.div_ceil(2).max(1);
    for i in start..nf {
        if scales[i] - scales[i - 1] > jump {
            return Some(scales[i]);
        }
    }
    Some(scales[nf - 1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Barap, Bconf, Sarap, Sd};
    use crate::generate::generate;
    use crate::hessian::count_negative;
    use crate::problem::Evaluation;

    #[test]
    fn tutte_is_injective_and_on_the_circle() {
        for name in ["flat_disk_1k", "cap_2k", "bumpy_1k"] {
            let mesh = generate(name).unwrap().normalized();
            for b in [TutteBoundary::Uniform, TutteBoundary::Arclength] {
                let x = tutte(&mesh, b).unwrap();
                let pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
                assert_eq!(pb.flips(&x), 0, "{name}");
                assert!(pb.energy(&x).is_finite());
                let loops = boundary_loops(&mesh.faces, mesh.n_vertices());
                let r = (1.0 / std::f64::consts::PI).sqrt();
                for &v in &loops[0] {
                    assert!(((x[2 * v].powi(2) + x[2 * v + 1].powi(2)).sqrt() - r).abs() < 1e-12);
                }
                // Interior vertices are the average of their neighbours (uniform weights).
                let nb = vertex_neighbors(&mesh.faces, mesh.n_vertices());
                let on_b: std::collections::HashSet<usize> = loops[0].iter().copied().collect();
                for v in (0..mesh.n_vertices()).filter(|v| !on_b.contains(v)) {
                    let k = nb[v].len() as f64;
                    let cu: f64 = nb[v].iter().map(|&w| x[2 * w]).sum::<f64>() / k;
                    assert!((cu - x[2 * v]).abs() < 1e-10);
                }
            }
        }
    }

    #[test]
    fn element_scale_is_the_smallest_psd_scale() {
        use crate::energy::tests::{random_xy, Lcg};
        let mut rng = Lcg(41);
        for e in [
            EnergyKind::Sd(Sd),
            EnergyKind::Bconf(Bconf { k: 0.1 }),
            EnergyKind::Barap(Barap { k: 0.1 }),
            EnergyKind::Barap(Barap { k: 2.0 }),
        ] {
            for _ in 0..500 {
                let (x, y) = random_xy(&mut rng);
                let (x, y) = (0.05 * x, 0.05 * y); // shrunken: mostly indefinite
                let st = |s: f64| {
                    let (xs, ys) = (s * s * x, s * s * y);
                    ElementState { fz: [xs.sqrt(), 0.0], fzb: [0.0, ys.sqrt()], m: e.modifiers(xs, ys).unwrap() }
                };
                let s = element_psd_scale(&e, &st(1.0)).unwrap();
                assert!(st(s * (1.0 + 1e-9)).m.a1 >= 0.0, "{e:?}");
                assert!(st(s * (1.0 - 1e-6)).m.a1 < 0.0, "{e:?}");
                assert_eq!(count_negative(&st(s * 1.000001)), 0, "{e:?}");
            }
        }
    }

    #[test]
    fn global_scale_without_jump_makes_every_element_psd() {
        // The Tutte map of the cap has no jump > 0.1 in the upper half of its sorted scales:
        // the rule returns the maximum, the smallest scale with every element Hessian PSD.
        let mesh = generate("cap_2k").unwrap().normalized();
        let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
        let pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let s = global_scale(&pb, &x, 0.1).unwrap();
        let scaled: Vec<f64> = x.iter().map(|v| v * s * (1.0 + 1e-9)).collect();
        let mut ev = Evaluation::default();
        pb.evaluate(&scaled, &mut ev).unwrap();
        assert_eq!(ev.neg_eig, 0);
        let shrunk: Vec<f64> = x.iter().map(|v| v * s * (1.0 - 1e-6)).collect();
        pb.evaluate(&shrunk, &mut ev).unwrap();
        assert!(ev.neg_eig > 0);
        // With a huge threshold the rule always falls back to the maximum.
        assert_eq!(global_scale(&pb, &x, f64::INFINITY), Some(s));
    }

    #[test]
    fn global_scale_stops_at_the_first_jump_past_the_middle() {
        // The flat disk's uniform-angle boundary gives a few outlying scales (a jump of 0.13).
        let mesh = generate("flat_disk_1k").unwrap().normalized();
        let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
        let pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let mut scales: Vec<f64> = (0..pb.n_faces())
            .map(|t| {
                let w = pb.ops[t].wirtinger(pb.target(&x, t));
                let m = pb.energy.modifiers(w.x(), w.y()).unwrap();
                element_psd_scale(&pb.energy, &ElementState::new(w, m)).unwrap()
            })
            .collect();
        scales.sort_by(f64::total_cmp);
        let s = global_scale(&pb, &x, 0.1).unwrap();
        let i = scales.iter().position(|&v| v == s).unwrap();
        assert!(i >= scales.len() / 2);
        // every gap between the middle and the pick is below the threshold
        for j in scales.len().div_ceil(2).max(1)..i {
            assert!(scales[j] - scales[j - 1] <= 0.1);
        }
        assert!(i < scales.len() - 1 && scales[i] - scales[i - 1] > 0.1, "no jump found");
        assert_eq!(global_scale(&MapProblem::new(&mesh, EnergyKind::Sarap(Sarap)).unwrap(), &x, 0.1), None);
    }
}
