//! A planar map optimization problem: the source mesh's local operators, an energy, and
//! evaluation of energy, gradient and element states at a map.
//!
//! The energy is `sum_t A_t psi_t / sum_t A_t` (docs/src/design/numerics.md): SD scores 2 at an isometry.
//! Maps are stored as interleaved `[u0, v0, u1, v1, ...]`.

use crate::assembly::Pattern;
use crate::energy::EnergyKind;
use crate::hessian::{count_negative, element_gradient, element_hessian, ElementState};
use crate::local::{local_ops, signed_area, LocalOp};
use crate::mesh::topology::VertexCorners;
use crate::mesh::Mesh;
use crate::smoothness::{self, Projection, Smoothness, Vector8};
use rayon::prelude::*;

/// Elements per parallel chunk; fixed so that floating-point sums do not depend on how
/// rayon splits the work (deterministic results for any thread count).
const CHUNK: usize = 2048;

/// Why a map could not be evaluated; always the lowest failing element.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum EvalError {
    /// The map inverts or collapses an element: outside the energy's domain `det J > 0`.
    #[error("element {element} is inverted or degenerate (det J = {det:e})")]
    NotInDomain {
        /// The face index.
        element: usize,
        /// Jacobian determinant `|f_z|^2 - |f_zbar|^2` of the element (not positive, or NaN).
        det: f64,
    },
    /// The energy density or its gradient is NaN or infinite on an element.
    #[error("element {element} has a non-finite energy or derivative (psi = {psi})")]
    NonFinite {
        /// The face index.
        element: usize,
        /// The element's energy density (finite when only the gradient is not).
        psi: f64,
    },
}

/// A source face with no local operator, so no problem can be built on the mesh.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[error("{source_name}: face {face} is degenerate (zero area) and has no local frame")]
pub struct DegenerateFace {
    /// The mesh source (file path or `generated:<name>`).
    pub source_name: String,
    /// The first degenerate face.
    pub face: usize,
}

/// The source mesh's per-face operators with an energy and optional extra terms: all a
/// solver needs to evaluate a map.
pub struct MapProblem {
    /// Number of vertices; the map has twice as many dofs.
    pub n_vertices: usize,
    /// The source mesh's faces.
    pub faces: Vec<[usize; 3]>,
    /// The local operator of each face, in face order.
    pub ops: Vec<LocalOp>,
    /// Sum of the source areas of `ops`: the normalizer of the energy.
    pub total_area: f64,
    /// The distortion energy density `psi`.
    pub energy: EnergyKind,
    /// Soft positional constraints of the `deform` task.
    pub penalty: Option<Penalty>,
    /// The energy smoothness term (Section 4.3), added to the normalized energy.
    pub smoothness: Option<Smoothness>,
    /// The faces around each vertex, for summing the gradient per vertex in parallel.
    incidence: VertexCorners,
}

/// Soft handles `lambda * sum |z_P - c|^2` (docs/src/design/numerics.md: gradient `2 lambda (z_P - c)`,
/// Hessian `2 lambda`, one consistent convention); added to the normalized energy.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Penalty {
    /// Weight of the handle term (on the area-1 mesh).
    pub lambda: f64,
    /// `(vertex, target)` pairs.
    pub handles: Vec<(usize, [f64; 2])>,
}

impl Penalty {
    /// The handle term `lambda * sum |z_P - c|^2` at the map `x`.
    pub fn value(&self, x: &[f64]) -> f64 {
        self.lambda
            * self.handles.iter().map(|&(v, c)| (x[2 * v] - c[0]).powi(2) + (x[2 * v + 1] - c[1]).powi(2)).sum::<f64>()
    }

    /// Add the handle term's gradient `2 lambda (z_P - c)` at `x` into `grad`.
    pub fn add_gradient(&self, x: &[f64], grad: &mut [f64]) {
        for &(v, c) in &self.handles {
            grad[2 * v] += 2.0 * self.lambda * (x[2 * v] - c[0]);
            grad[2 * v + 1] += 2.0 * self.lambda * (x[2 * v + 1] - c[1]);
        }
    }

    /// The Hessian: `2 lambda` on both dofs of every handle (repeats add up).
    pub fn diagonal(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.handles.iter().flat_map(move |&(v, _)| [(2 * v, 2.0 * self.lambda), (2 * v + 1, 2.0 * self.lambda)])
    }
}

/// Result of a full evaluation (energy, gradient, per-element states and Hessian inertia).
#[derive(Clone, Debug, Default)]
pub struct Evaluation {
    /// The full objective: normalized energy plus handle and smoothness terms.
    pub energy: f64,
    /// Gradient of `energy`, interleaved like the map.
    pub grad: Vec<f64>,
    /// Each face's state at the map, in face order (input to the element Hessians).
    pub states: Vec<ElementState>,
    /// Negative eigenvalues summed over the unmodified element Hessians.
    pub neg_eig: usize,
    /// Elements with at least one negative eigenvalue.
    pub indefinite_elems: usize,
    /// Per-element weighted energy and local gradient (reused across evaluations).
    locals: Vec<[f64; 7]>,
    /// Per-edge smoothness value and gradient (reused across evaluations).
    edge_terms: Vec<(f64, Vector8)>,
}

/// Buffers of the energy-only evaluation, reused across the line search's trials (the
/// partial sums keep the summation order fixed, hence the same bits for any thread count).
#[derive(Clone, Debug, Default)]
pub struct EnergyScratch {
    partial: Vec<f64>,
    densities: Vec<f64>,
    edge_partial: Vec<f64>,
}

impl MapProblem {
    /// The Newton system's pattern: faces, plus edge pairs with a smoothness term.
    pub fn system_pattern(&self) -> Pattern {
        match &self.smoothness {
            Some(sm) => Pattern::with_edges(&self.faces, &sm.edge_vertices(), self.n_vertices),
            None => Pattern::new(&self.faces, self.n_vertices),
        }
    }

    /// The problem of `energy` on `mesh`, without handles or smoothness term; fails on the
    /// first face with no local operator.
    pub fn new(mesh: &Mesh, energy: EnergyKind) -> Result<Self, DegenerateFace> {
        let ops = local_ops(mesh).map_err(|face| DegenerateFace { source_name: mesh.source.clone(), face })?;
        let total_area = ops.iter().map(|o| o.area).sum();
        Ok(MapProblem {
            n_vertices: mesh.n_vertices(),
            faces: mesh.faces.clone(),
            ops,
            total_area,
            energy,
            penalty: None,
            smoothness: None,
            incidence: VertexCorners::new(&mesh.faces, mesh.n_vertices()),
        })
    }

    /// Add the smoothness term `w sum_e l_e (psi_i - psi_j)^2` over the interior edges of
    /// `mesh` (the rest mesh this problem was built from).
    pub fn with_smoothness(mut self, mesh: &Mesh, weight: f64, projection: Projection) -> Self {
        self.smoothness = Some(Smoothness::new(weight, projection, &self.faces, &mesh.positions, &self.ops));
        self
    }

    /// Number of unknowns: `u` and `v` of every vertex.
    pub fn n_dofs(&self) -> usize {
        2 * self.n_vertices
    }

    /// Number of faces (elements).
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// The image of face `t` under the map `x`: its three corners `[u, v]`.
    #[inline]
    pub fn target(&self, x: &[f64], t: usize) -> [[f64; 2]; 3] {
        let f = self.faces[t];
        [[x[2 * f[0]], x[2 * f[0] + 1]], [x[2 * f[1]], x[2 * f[1] + 1]], [x[2 * f[2]], x[2 * f[2] + 1]]]
    }

    /// Energy only (for line searches): `+inf` if any element is inverted or degenerate.
    pub fn energy(&self, x: &[f64]) -> f64 {
        self.energy_with(x, &mut EnergyScratch::default())
    }

    /// [`MapProblem::energy`] with the buffers of `scratch` (no allocation once they have grown).
    pub fn energy_with(&self, x: &[f64], scratch: &mut EnergyScratch) -> f64 {
        let psi = |t: usize| {
            let w = self.ops[t].wirtinger(self.target(x, t));
            self.energy.value(w.x(), w.y())
        };
        // With a smoothness term each density is needed by up to four sums: compute it once.
        let with_densities = self.smoothness.is_some();
        if with_densities {
            (0..self.n_faces()).into_par_iter().with_min_len(CHUNK).map(psi).collect_into_vec(&mut scratch.densities);
        }
        let densities = &scratch.densities;
        let density = |t: usize| if with_densities { densities[t] } else { psi(t) };
        (0..self.n_faces())
            .into_par_iter()
            .with_min_len(CHUNK)
            .chunks(CHUNK)
            .map(|chunk| chunk.into_iter().map(|t| self.ops[t].area * density(t)).sum::<f64>())
            .collect_into_vec(&mut scratch.partial);
        let mut e =
            scratch.partial.iter().sum::<f64>() / self.total_area + self.penalty.as_ref().map_or(0.0, |p| p.value(x));
        if let (Some(sm), true) = (&self.smoothness, with_densities) {
            if e.is_finite() {
                let d = &scratch.densities;
                (0..sm.pairs.len())
                    .into_par_iter()
                    .with_min_len(CHUNK)
                    .chunks(CHUNK)
                    .map(|chunk| {
                        chunk
                            .into_iter()
                            .map(|k| {
                                let [i, j] = sm.pairs[k].faces;
                                sm.coefficient(k) * (d[i] - d[j]).powi(2)
                            })
                            .sum::<f64>()
                    })
                    .collect_into_vec(&mut scratch.edge_partial);
                e += scratch.edge_partial.iter().sum::<f64>();
            }
        }
        e
    }

    /// Number of triangles whose image's signed area is not positive (non-finite included:
    /// a NaN coordinate flips every face it touches).
    pub fn flips(&self, x: &[f64]) -> usize {
        (0..self.n_faces()).into_par_iter().filter(|&t| !(signed_area(self.target(x, t)) > 0.0)).count()
    }

    /// The signed singular values `(sigma1, sigma2)` of each element's Jacobian at `x`
    /// (`sigma2 <= 0` where the map inverts or collapses the element).
    pub fn singular_values(&self, x: &[f64]) -> Vec<[f64; 2]> {
        (0..self.n_faces())
            .into_par_iter()
            .map(|t| self.ops[t].wirtinger(self.target(x, t)).singular_values())
            .collect()
    }

    /// Energy, gradient, element states and inertia counts at `x`, reusing `out`'s buffers.
    ///
    /// One parallel pass over the faces in fixed chunks computes each element's state,
    /// weighted energy, local gradient and inertia; a second, parallel over the vertices,
    /// sums the gradient in face order ([`VertexCorners`]); the energy is summed in face order.
    /// Nothing is allocated once `out` has grown, and the result is the same bits for any
    /// thread count.
    pub fn evaluate(&self, x: &[f64], out: &mut Evaluation) -> Result<(), EvalError> {
        self.evaluate_counting(x, out, true)
    }

    /// [`MapProblem::evaluate`] without the inertia counts (`neg_eig` and `indefinite_elems`
    /// left 0): for a method that needs only the energy and gradient, whose counts are for
    /// the record alone and timed apart ([`MapProblem::count_inertia`]).
    pub fn evaluate_without_inertia(&self, x: &[f64], out: &mut Evaluation) -> Result<(), EvalError> {
        self.evaluate_counting(x, out, false)
    }

    /// The inertia counts of the element states of `ev` into it: the same as
    /// [`MapProblem::evaluate`]'s (integer sums, in any order).
    pub fn count_inertia(&self, ev: &mut Evaluation) {
        (ev.neg_eig, ev.indefinite_elems) = ev
            .states
            .par_iter()
            .with_min_len(CHUNK)
            .map(|st| {
                let n = count_negative(st);
                (n, usize::from(n > 0))
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    }

    fn evaluate_counting(&self, x: &[f64], out: &mut Evaluation, inertia: bool) -> Result<(), EvalError> {
        let nf = self.n_faces();
        out.states.resize(nf, ElementState::default());
        out.locals.resize(nf, [0.0; 7]);
        // Per chunk: the first failure, or the chunk's (negative eigenvalues, indefinite
        // elements); the integer counts add up in any order.
        let chunk = |c: usize, states: &mut [ElementState], locals: &mut [[f64; 7]]| {
            let mut counts = (0usize, 0usize);
            for (i, (st, loc)) in states.iter_mut().zip(locals.iter_mut()).enumerate() {
                let t = c * CHUNK + i;
                let op = &self.ops[t];
                let w = op.wirtinger(self.target(x, t));
                let (xx, yy) = (w.x(), w.y());
                let m = self.energy.modifiers(xx, yy).ok_or(EvalError::NotInDomain { element: t, det: xx - yy })?;
                *st = ElementState::new(w, m);
                let g = element_gradient(op, st);
                if !m.psi.is_finite() || g.iter().any(|v| !v.is_finite()) {
                    return Err(EvalError::NonFinite { element: t, psi: m.psi });
                }
                loc[0] = op.area * m.psi;
                loc[1..].copy_from_slice(g.as_slice());
                if inertia {
                    let n = count_negative(st);
                    counts = (counts.0 + n, counts.1 + usize::from(n > 0));
                }
            }
            Ok(counts)
        };
        let counts = out
            .states
            .par_chunks_mut(CHUNK)
            .zip(out.locals.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (states, locals))| chunk(c, states, locals))
            // The first failing chunk in order: the lowest failing element, a stable message.
            .try_reduce(|| (0, 0), |a, b| Ok((a.0 + b.0, a.1 + b.1)));
        (out.neg_eig, out.indefinite_elems) = match counts {
            Ok(c) => c,
            Err(e) => return Err(self.first_failure(x, e)),
        };
        let inv = 1.0 / self.total_area;
        let locals = &out.locals;
        out.grad.resize(self.n_dofs(), 0.0);
        out.grad.par_chunks_mut(2).with_min_len(CHUNK).enumerate().for_each(|(v, g)| {
            let (mut gu, mut gv) = (0.0, 0.0);
            for &corner in self.incidence.of(v) {
                let (t, k) = (corner as usize / 3, corner as usize % 3);
                gu += locals[t][1 + 2 * k] * inv;
                gv += locals[t][2 + 2 * k] * inv;
            }
            g[0] = gu;
            g[1] = gv;
        });
        out.energy = locals.iter().map(|loc| loc[0]).sum::<f64>() * inv;
        if let Some(p) = &self.penalty {
            out.energy += p.value(x);
            p.add_gradient(x, &mut out.grad);
        }
        if let Some(sm) = &self.smoothness {
            let st = &out.states;
            (0..sm.pairs.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .map(|k| {
                    let [i, j] = sm.pairs[k].faces;
                    let c = sm.coefficient(k);
                    (smoothness::value(c, &st[i], &st[j]), smoothness::gradient(c, &st[i], &st[j], &sm.ops[k]))
                })
                .collect_into_vec(&mut out.edge_terms);
            // Sequential sums and scatter: the same bits for any thread count.
            for ((v, g), pair) in out.edge_terms.iter().zip(&sm.pairs) {
                out.energy += v;
                for (slot, &vert) in pair.verts.iter().enumerate() {
                    out.grad[2 * vert] += g[2 * slot];
                    out.grad[2 * vert + 1] += g[2 * slot + 1];
                }
            }
        }
        Ok(())
    }

    /// The failure of the lowest failing element. `try_reduce` may stop at any failing chunk;
    /// the reported element must not depend on the thread count, so the chunks before the
    /// failing one are checked again in order (a failure is the end of a run: no hot path).
    fn first_failure(&self, x: &[f64], found: EvalError) -> EvalError {
        let last = match found {
            EvalError::NotInDomain { element, .. } | EvalError::NonFinite { element, .. } => element,
        };
        for t in 0..last {
            let op = &self.ops[t];
            let w = op.wirtinger(self.target(x, t));
            let (xx, yy) = (w.x(), w.y());
            let Some(m) = self.energy.modifiers(xx, yy) else {
                return EvalError::NotInDomain { element: t, det: xx - yy };
            };
            let g = element_gradient(op, &ElementState::new(w, m));
            if !m.psi.is_finite() || g.iter().any(|v| !v.is_finite()) {
                return EvalError::NonFinite { element: t, psi: m.psi };
            }
        }
        found
    }

    /// `s^T H s` with `H` the unmodified Hessian of the energy at the iterate `ev` was
    /// evaluated at: the element Hessians, the smoothness term's exact 8x8 blocks and the
    /// handles' `2 lambda` (the trust-region model of `pn-trust-region`). Sums in fixed chunks
    /// and in order, so the same bits for any thread count.
    pub fn hessian_form(&self, ev: &Evaluation, s: &[f64]) -> f64 {
        let local = |verts: &[usize], out: &mut [f64]| {
            for (k, &v) in verts.iter().enumerate() {
                out[2 * k] = s[2 * v];
                out[2 * k + 1] = s[2 * v + 1];
            }
        };
        let faces: Vec<f64> = (0..self.n_faces())
            .into_par_iter()
            .fold_chunks(
                CHUNK,
                || 0.0,
                |acc, t| {
                    let mut d = nalgebra::Vector6::zeros();
                    local(&self.faces[t], d.as_mut_slice());
                    acc + d.dot(&(element_hessian(&self.ops[t], &ev.states[t]) * d))
                },
            )
            .collect();
        let mut form = faces.iter().sum::<f64>() / self.total_area;
        if let Some(sm) = &self.smoothness {
            let edges: Vec<f64> = (0..sm.pairs.len())
                .into_par_iter()
                .fold_chunks(
                    CHUNK,
                    || 0.0,
                    |acc, k| {
                        let [i, j] = sm.pairs[k].faces;
                        let b = smoothness::block(
                            sm.coefficient(k),
                            &ev.states[i],
                            &ev.states[j],
                            &sm.ops[k],
                            Projection::Exact,
                        );
                        let mut d = Vector8::zeros();
                        local(&sm.pairs[k].verts, d.as_mut_slice());
                        acc + d.dot(&(b * d))
                    },
                )
                .collect();
            form += edges.iter().sum::<f64>();
        }
        if let Some(p) = &self.penalty {
            form += p.diagonal().map(|(dof, h)| h * s[dof] * s[dof]).sum::<f64>();
        }
        form
    }

    /// The weight of an element's area in the normalized energy: one over the total area.
    #[inline]
    pub fn weight(&self) -> f64 {
        1.0 / self.total_area
    }
}

/// Euclidean norm.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Euclidean inner product, summed in order (the same bits on every call).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::{all_energies, Lcg};
    use crate::energy::Sd;

    fn grid(n: usize) -> Mesh {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                p.push([x, y, 0.3 * (3.0 * x).sin() * (2.0 * y).cos()]);
            }
        }
        let mut f = Vec::new();
        let id = |i: usize, j: usize| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        Mesh::new("grid", p, f)
    }

    /// The evaluation without the inertia counts is the full one's energy and gradient bit
    /// for bit, and counting afterwards gives its counts (some positive here).
    #[test]
    fn inertia_counted_apart_is_the_evaluation_s() {
        let mesh = grid(8);
        let mut rng = Lcg(3);
        let x: Vec<f64> = mesh
            .positions
            .iter()
            .flat_map(|p| [1.7 * p[0] + rng.range(-0.01, 0.01), 0.6 * p[1] + 0.2 * p[0]])
            .collect();
        let mut negative = 0;
        for energy in all_energies() {
            let pb = MapProblem::new(&mesh, energy).unwrap();
            let (mut full, mut apart) = (Evaluation::default(), Evaluation::default());
            pb.evaluate(&x, &mut full).unwrap();
            pb.evaluate_without_inertia(&x, &mut apart).unwrap();
            assert_eq!((apart.neg_eig, apart.indefinite_elems), (0, 0));
            assert_eq!((apart.energy.to_bits(), &apart.grad), (full.energy.to_bits(), &full.grad), "{energy:?}");
            pb.count_inertia(&mut apart);
            assert_eq!((apart.neg_eig, apart.indefinite_elems), (full.neg_eig, full.indefinite_elems), "{energy:?}");
            negative += full.neg_eig;
        }
        assert!(negative > 0);
    }

    #[test]
    fn global_gradient_matches_central_differences() {
        let mesh = grid(4);
        let mut rng = Lcg(31);
        for e in all_energies() {
            let pb = MapProblem::new(&mesh, e).unwrap();
            // a mildly distorted planar map of the grid
            let x: Vec<f64> = mesh
                .positions
                .iter()
                .flat_map(|p| [1.1 * p[0] + 0.2 * p[1] * p[1], 0.9 * p[1] + 0.1 * p[0]])
                .map(|v| v + 0.003 * rng.range(-1.0, 1.0))
                .collect();
            let mut ev = Evaluation::default();
            pb.evaluate(&x, &mut ev).unwrap();
            assert!((ev.energy - pb.energy(&x)).abs() < 1e-12 * ev.energy.abs().max(1.0));
            for i in 0..x.len() {
                let h = 1e-6;
                let mut xp = x.clone();
                xp[i] += h;
                let mut xm = x.clone();
                xm[i] -= h;
                let fd = (pb.energy(&xp) - pb.energy(&xm)) / (2.0 * h);
                assert!(
                    (fd - ev.grad[i]).abs() < 1e-6 * ev.grad.iter().fold(1.0f64, |a, v| a.max(v.abs())),
                    "{e:?} {i}"
                );
            }
        }
    }

    /// `s^T H s` against central differences of the gradient along `s`, for every energy, with
    /// the smoothness term and soft handles (every part of the Hessian the model needs).
    #[test]
    fn hessian_form_matches_differences_of_the_gradient() {
        let mesh = grid(4);
        let mut rng = Lcg(37);
        for e in all_energies() {
            let mut pb = MapProblem::new(&mesh, e).unwrap().with_smoothness(&mesh, 0.3, Projection::Analytic);
            pb.penalty = Some(Penalty { lambda: 2.0, handles: vec![(0, [0.1, -0.2]), (12, [0.5, 0.5])] });
            let x: Vec<f64> = mesh
                .positions
                .iter()
                .flat_map(|p| [1.1 * p[0] + 0.2 * p[1] * p[1], 0.9 * p[1] + 0.1 * p[0]])
                .map(|v| v + 0.003 * rng.range(-1.0, 1.0))
                .collect();
            let s: Vec<f64> = x.iter().map(|_| rng.range(-1.0, 1.0)).collect();
            let (mut ev, mut ep, mut em) = (Evaluation::default(), Evaluation::default(), Evaluation::default());
            pb.evaluate(&x, &mut ev).unwrap();
            let h = 1e-6;
            let shifted = |t: f64| x.iter().zip(&s).map(|(a, b)| a + t * b).collect::<Vec<f64>>();
            pb.evaluate(&shifted(h), &mut ep).unwrap();
            pb.evaluate(&shifted(-h), &mut em).unwrap();
            let fd: f64 = ep.grad.iter().zip(&em.grad).zip(&s).map(|((p, m), si)| (p - m) / (2.0 * h) * si).sum();
            let form = pb.hessian_form(&ev, &s);
            assert!((fd - form).abs() <= 1e-6 * form.abs().max(1.0), "{e:?}: {fd} vs {form}");
            // the handles alone: 2 lambda per constrained dof
            let mut only = MapProblem::new(&mesh, e).unwrap();
            let no_handles = only.hessian_form(&ev, &s);
            only.penalty = pb.penalty.clone();
            let want = 4.0 * (s[0] * s[0] + s[1] * s[1] + s[24] * s[24] + s[25] * s[25]);
            assert!((only.hessian_form(&ev, &s) - no_handles - want).abs() <= 1e-12 * want.max(1.0), "{e:?}");
        }
    }

    #[test]
    fn inverted_map_has_infinite_energy_and_typed_error() {
        let mesh = grid(2);
        let pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let mut x: Vec<f64> = mesh.positions.iter().flat_map(|p| [p[0], p[1]]).collect();
        x[2 * 4] = 2.0; // push the centre vertex far out: folds triangles
        assert_eq!(pb.energy(&x), f64::INFINITY);
        assert!(pb.flips(&x) > 0);
        let err = pb.evaluate(&x, &mut Evaluation::default()).unwrap_err();
        assert!(matches!(err, EvalError::NotInDomain { .. }));
    }
}
