//! The authalic problem on a mesh: the energy's terms and gradient on a fixed sparsity
//! pattern, the run's settings and outcome, and why a run could not start.

use crate::laplacian::{stretch_weights, LaplacianPattern, SubBlock};
use crate::linear::{AnalysisCache, LinearError, LinearSettings, SpdSolver};
use crate::mesh::topology::{boundary_loops, VertexCorners};
use crate::mesh::Mesh;
use crate::solver::{Outcome, StopSettings};
use crate::tasks::solver_error::SolverError;
use crate::tasks::{validate_for, Task};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Faces per parallel chunk (fixed: sums do not depend on the thread count).
const CHUNK: usize = 2048;

/// The one energy of the `authalic` task (the name in CSVs and configs): the normalized
/// authalic energy of Liu and Yueh, not a density of `f_z`, `f_zbar` like the others.
pub const AUTHALIC_ENERGY: &str = "authalic";

/// Why an `authalic` run could not start.
#[derive(Debug, thiserror::Error)]
pub enum AuthalicError {
    /// The solver is unknown or not an authalic solver.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// The mesh failed validation for the `authalic` task.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// A face has no positive area once the mesh is scaled to area `pi`.
    #[error("{source_name}: face {face} has zero source area")]
    DegenerateFace {
        /// The mesh source.
        source_name: String,
        /// The first such face.
        face: usize,
    },
    /// The mesh does not have exactly one boundary loop.
    #[error("{source_name}: the mesh has {count} boundary loops; the authalic task needs exactly one (a disk)")]
    BoundaryLoops {
        /// The mesh source.
        source_name: String,
        /// Number of boundary loops found.
        count: usize,
    },
    /// Every vertex lies on the boundary.
    #[error("{source_name}: the mesh has no interior vertex")]
    NoInterior {
        /// The mesh source.
        source_name: String,
    },
    /// A linear solve of the initial map's stretch steps failed.
    #[error("{source_name}: initialization failed: {what}: {err}")]
    Init {
        /// The mesh source.
        source_name: String,
        /// The step that failed (`analysis of L_II` or `L_II solve`).
        what: &'static str,
        /// The linear solver's error.
        err: LinearError,
    },
    /// The initial map has a NaN or infinite variable.
    #[error("{source_name}: the initial map is not valid: {what}")]
    InitNotFinite {
        /// The mesh source.
        source_name: String,
        /// Which variable of `z` (`variable <i>`).
        what: String,
    },
    /// A map given to start from does not fit the mesh.
    #[error("{source_name}: the given map: {detail}")]
    BadMap {
        /// The mesh source.
        source_name: String,
        /// What is wrong with it.
        detail: String,
    },
}

/// What the fold guard of `aem-cg-safe` rejects.
///
/// The normalized authalic energy has no barrier: on the shared corpus the faithful method's
/// path folds a few interior triangles for some iterations and unfolds them later (human_face:
/// 2 folds at iterations 42-47, none at 100). Forbidding any new fold (`All`) therefore stalls
/// the descent against the fold constraint; the default guards only the constraint of Eq. 10.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FoldGuard {
    /// No guard.
    None,
    /// Reject steps that break the cyclic order of the boundary angles (Eq. 10).
    #[default]
    Boundary,
    /// Reject steps that fold more triangles than the current map has.
    All,
}

/// Settings of an `authalic` run (`[authalic]` and `[stop]` in a config).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AuthalicSettings {
    /// Not a key of `[authalic]`: the config's `[stop]` is laid over the paper's protocol
    /// ([`default_stop`]); a partial nested table would otherwise take the other fields
    /// from `StopSettings::default()`.
    #[serde(skip_deserializing)]
    pub stop: StopSettings,
    /// Fixed-boundary stretch steps of the initialization (Algorithm 1, lines 4-7).
    pub init_steps: usize,
    /// Initial trial step `alpha_0` of the quadratic step rule (Section 3.1).
    pub alpha0: f64,
    /// `aem-cg-safe`: Armijo constant `c1` of (22a).
    pub armijo_c: f64,
    /// Curvature constant `c2` of (22b), recorded (`wolfe` column) for both AEM variants;
    /// the convergence proof needs `c2 < 1/2`.
    pub wolfe_c2: f64,
    /// `aem-cg-safe`: step halvings before a restart / giving up.
    pub max_backtracks: usize,
    /// `aem-cg-safe`: what the fold guard rejects.
    pub fold_guard: FoldGuard,
    /// `sem`: stop and keep the previous iterate when a step increases the energy (the
    /// reference code SEMc); off by default, as the paper's Table 1 runs a fixed budget.
    pub sem_stop_on_increase: bool,
}

impl Default for AuthalicSettings {
    fn default() -> Self {
        AuthalicSettings {
            stop: default_stop(),
            init_steps: 5,
            alpha0: 2.0,
            armijo_c: 1e-4,
            wolfe_c2: 0.45,
            max_backtracks: 30,
            fold_guard: FoldGuard::Boundary,
            sem_stop_on_increase: false,
        }
    }
}

/// The paper's Table 1 protocol: a fixed budget of 100 iterations, no tolerance stop.
pub fn default_stop() -> StopSettings {
    StopSettings::rules_only(0.0, 0.0, 100)
}

/// Area-distortion metrics of a map (docs/src/reference/columns.md): the normalized ratio
/// `r = (|f(t)| / A(f)) / (|t| / |S|)` per face.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AreaMetrics {
    /// Population standard deviation of `r`.
    pub area_ratio_sd: f64,
    /// Mean of `|r - 1|`.
    pub area_ratio_mad: f64,
    /// Normalized authalic energy (Eq. 4).
    pub authalic_energy: f64,
    /// Faces with non-positive signed image area.
    pub folded: usize,
}

/// Result of an authalic run: the solver outcome plus the final metrics.
#[derive(Clone, Debug)]
pub struct AuthalicOutcome {
    /// The run; its map `x` is the interleaved image positions, boundary on the unit circle.
    pub outcome: Outcome,
    /// Area distortion of the last iterate.
    pub metrics: AreaMetrics,
}

/// The image positions and per-face gradient coefficients of an evaluation, kept between
/// iterations: at 1M vertices each is 16 MB, which a fresh allocation faults in and zeroes.
#[derive(Default)]
pub(crate) struct EvalBuffers {
    x: Vec<f64>,
    coef: Vec<f64>,
}

/// Energy terms at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terms {
    /// Normalized authalic energy `(|S| / A) E_S - A` (Eq. 4).
    pub energy: f64,
    /// Stretch energy `E_S = sum |f(tau)|^2 / |tau|` (Eq. 2b, Lemma in Theorem 1's proof).
    pub stretch: f64,
    /// Image area from the boundary polygon (Eq. 8).
    pub area: f64,
    /// Faces with non-positive signed image area.
    pub folded: usize,
    /// Faces with non-zero image area (each contributes two negative eigenvalues).
    pub nonzero: usize,
}

/// A disk mesh prepared for the authalic task.
pub struct AuthalicProblem {
    /// The mesh source (file path or `generated:<name>`).
    pub source: String,
    /// The mesh's faces.
    pub faces: Vec<[usize; 3]>,
    /// Number of vertices.
    pub n: usize,
    /// Source positions scaled to total area `pi`, flat `[x, y, z, ...]`.
    pub positions: Vec<f64>,
    /// Source face areas `|tau|` (summing to `|S| = pi`).
    pub area: Vec<f64>,
    /// `|S|`, the sum of `area` (`pi` up to rounding).
    pub total_area: f64,
    /// Boundary loop in the faces' orientation (counter-clockwise in the image).
    pub boundary: Vec<usize>,
    /// Interior vertices in increasing order: the order of `f_I^1` and `f_I^2` in `z`.
    pub interior: Vec<usize>,
    /// Pattern of `L_S` over all vertices.
    pub pattern: LaplacianPattern,
    /// The `L_II` block, rows in `interior` order.
    pub block_i: SubBlock,
    /// The `L_BB` block, rows in `boundary` order (the order of `theta`).
    pub block_b: SubBlock,
    /// Each vertex's corners, for the gradient's per-vertex sums.
    corners: VertexCorners,
    /// Where each vertex's image is in `z`: `i < n_interior` for `interior[i]`,
    /// `n_interior + b` for `boundary[b]` (the positions are a parallel gather by vertex).
    var_of: Vec<usize>,
    /// The blocks' analyses, computed once per problem: the initial map and the solver
    /// (AEM's preconditioner, SEM's steps) factorize the same `L_II` pattern, whose METIS
    /// analysis costs more than several factorizations on large meshes.
    analyses: AnalysisCache,
}

impl AuthalicProblem {
    /// Validate `mesh` (a disk, no degenerate faces) and scale it to area `pi`.
    pub fn new(mesh: &Mesh) -> Result<AuthalicProblem, AuthalicError> {
        validate_for(mesh, Task::Authalic).into_result()?;
        let n = mesh.n_vertices();
        let total = mesh.total_area();
        let (s, area): (f64, Vec<f64>) = if total.is_normal() {
            let s = (PI / total).sqrt();
            (s, (0..mesh.n_faces()).map(|t| mesh.face_area(t) * s * s).collect())
        } else {
            // Areas over- or underflow in the file's units: the scale of the area-1
            // normalization (computed at unit extent), areas measured after scaling.
            let s = PI.sqrt() * mesh.normalization().1;
            (s, (0..mesh.n_faces()).map(|t| mesh.face_area_scaled(t, s)).collect())
        };
        let positions: Vec<f64> = mesh.positions.iter().flat_map(|p| p.map(|c| c * s)).collect();
        if let Some(face) = area.iter().position(|a| !(*a > 0.0)) {
            return Err(AuthalicError::DegenerateFace { source_name: mesh.source.clone(), face });
        }
        let total_area = area.iter().sum();
        let loops = boundary_loops(&mesh.faces, n);
        if loops.len() != 1 {
            return Err(AuthalicError::BoundaryLoops { source_name: mesh.source.clone(), count: loops.len() });
        }
        let boundary = loops.into_iter().next().unwrap_or_default();
        let mut is_b = vec![false; n];
        boundary.iter().for_each(|&v| is_b[v] = true);
        let interior: Vec<usize> = (0..n).filter(|&v| !is_b[v]).collect();
        if interior.is_empty() {
            return Err(AuthalicError::NoInterior { source_name: mesh.source.clone() });
        }
        let pattern = LaplacianPattern::new(&mesh.faces, n);
        let local = |set: &[usize]| {
            let mut l = vec![usize::MAX; n];
            set.iter().enumerate().for_each(|(c, &v)| l[v] = c);
            l
        };
        let block_i = SubBlock::new(&pattern, &interior, &local(&interior));
        let block_b = SubBlock::new(&pattern, &boundary, &local(&boundary));
        let mut var_of = vec![0; n];
        interior.iter().enumerate().for_each(|(i, &v)| var_of[v] = i);
        boundary.iter().enumerate().for_each(|(b, &v)| var_of[v] = interior.len() + b);
        Ok(AuthalicProblem {
            source: mesh.source.clone(),
            faces: mesh.faces.clone(),
            n,
            positions,
            area,
            total_area,
            boundary,
            interior,
            pattern,
            block_i,
            block_b,
            corners: VertexCorners::new(&mesh.faces, n),
            var_of,
            analyses: AnalysisCache::new(),
        })
    }

    /// A solver of the Laplacian block `block` (`block_i` or `block_b`), analysed once. METIS
    /// nested dissection: its factors are sparser than AMD's on large disks, and every
    /// iteration's preconditioner solve reads the factor whole.
    pub fn block_solver(&self, block: &SubBlock) -> Result<SpdSolver, LinearError> {
        SpdSolver::from_csc_cached(
            block.n,
            &block.col_ptr,
            &block.row_idx,
            block.diag.clone(),
            crate::linear::ordering::Ordering::Metis,
            1,
            &self.analyses,
        )
    }

    /// Number of interior vertices.
    pub fn n_interior(&self) -> usize {
        self.interior.len()
    }

    /// Number of boundary vertices: the length of `theta`.
    pub fn n_boundary(&self) -> usize {
        self.boundary.len()
    }

    /// Length of the variable vector `z = [f_I^1; f_I^2; theta]`.
    pub fn n_vars(&self) -> usize {
        2 * self.n_interior() + self.n_boundary()
    }

    /// The interleaved image positions `[u0, v0, u1, v1, ...]` of `z`.
    pub fn positions_of(&self, z: &[f64]) -> Vec<f64> {
        let mut x = Vec::new();
        self.positions_into(z, &mut x);
        x
    }

    /// [`Self::positions_of`] into `x` (every entry written), in parallel over the vertices.
    fn positions_into(&self, z: &[f64], x: &mut Vec<f64>) {
        let ni = self.n_interior();
        x.resize(2 * self.n, 0.0);
        x.par_chunks_mut(2).zip(&self.var_of).with_min_len(CHUNK).for_each(|(xv, &k)| {
            if k < ni {
                (xv[0], xv[1]) = (z[k], z[ni + k]);
            } else {
                let th = z[ni + k];
                (xv[0], xv[1]) = (th.cos(), th.sin());
            }
        });
    }

    /// `z` of interleaved positions whose boundary lies on the unit circle; the angles are
    /// unwrapped along the loop starting in `[0, 2 pi)`.
    pub fn vars_of(&self, x: &[f64]) -> Vec<f64> {
        let ni = self.n_interior();
        let mut z = Vec::with_capacity(self.n_vars());
        z.extend(self.interior.iter().map(|&v| x[2 * v]));
        z.extend(self.interior.iter().map(|&v| x[2 * v + 1]));
        let mut prev: Option<f64> = None;
        for &v in &self.boundary {
            let a = x[2 * v + 1].atan2(x[2 * v]);
            let a = match prev {
                None => a.rem_euclid(2.0 * PI),
                Some(p) => p + (a - p + PI).rem_euclid(2.0 * PI) - PI,
            };
            prev = Some(a);
            z.push(a);
        }
        debug_assert_eq!(z.len(), 2 * ni + self.n_boundary());
        z
    }

    /// Whether the boundary angles of `z` keep their cyclic order (every gap positive, the
    /// loop winding once): the constraint of Eq. 10.
    pub fn boundary_ordered(&self, z: &[f64]) -> bool {
        let theta = &z[2 * self.n_interior()..];
        let nb = theta.len();
        theta.windows(2).all(|w| w[1] > w[0]) && theta[nb - 1] < theta[0] + 2.0 * PI
    }

    /// Signed image area of face `t`.
    pub(super) fn image_area(&self, x: &[f64], t: usize) -> f64 {
        let f = self.faces[t];
        crate::local::signed_area(f.map(|k| [x[2 * k], x[2 * k + 1]]))
    }

    /// Image area of the boundary polygon, `1/2 sum sin(theta_{i+1} - theta_i)` (Eq. 8).
    pub fn polygon_area(&self, theta: &[f64]) -> f64 {
        let nb = theta.len();
        0.5 * (0..nb).map(|i| (theta[(i + 1) % nb] - theta[i]).sin()).sum::<f64>()
    }

    /// `E_S` (deterministic chunked sum), folded faces, faces with non-zero image area.
    fn stretch(&self, x: &[f64]) -> (f64, usize, usize) {
        let nf = self.faces.len();
        let parts: Vec<(f64, usize, usize)> = (0..nf.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| self.chunk_stretch(x, c * CHUNK..nf.min((c + 1) * CHUNK), None))
            .collect();
        parts.iter().fold((0.0, 0, 0), |(e, k, nz), p| (e + p.0, k + p.1, nz + p.2))
    }

    /// [`Self::stretch`], also writing each face's gradient coefficient `2 |f(tau)| / |tau|`
    /// into `coef` (one entry per face): one pass over the faces for the energy and the
    /// gradient.
    fn stretch_and_coefficients(&self, x: &[f64], coef: &mut [f64]) -> (f64, usize, usize) {
        let nf = self.faces.len();
        let parts: Vec<(f64, usize, usize)> = coef
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, out)| self.chunk_stretch(x, c * CHUNK..nf.min((c + 1) * CHUNK), Some(out)))
            .collect();
        parts.iter().fold((0.0, 0, 0), |(e, k, nz), p| (e + p.0, k + p.1, nz + p.2))
    }

    /// The part of `E_S`, folded and non-zero counts of the faces `range`, summed in order;
    /// `coef[i]` gets `2 |f(tau)| / |tau|` of face `range.start + i` when given.
    fn chunk_stretch(
        &self,
        x: &[f64],
        range: std::ops::Range<usize>,
        mut coef: Option<&mut [f64]>,
    ) -> (f64, usize, usize) {
        let start = range.start;
        range.fold((0.0, 0, 0), |(e, k, nz), t| {
            let a = self.image_area(x, t);
            if let Some(c) = coef.as_deref_mut() {
                c[t - start] = 2.0 * a / self.area[t];
            }
            (e + a * a / self.area[t], k + usize::from(!(a > 0.0)), nz + usize::from(a != 0.0))
        })
    }

    /// Energy terms at `z`.
    pub fn terms(&self, z: &[f64]) -> Terms {
        self.terms_with(z, &mut EvalBuffers::default())
    }

    /// [`Self::terms`] with the image positions in `buf`.
    pub(crate) fn terms_with(&self, z: &[f64], buf: &mut EvalBuffers) -> Terms {
        self.positions_into(z, &mut buf.x);
        let x = &buf.x;
        let (stretch, folded, nonzero) = self.stretch(x);
        let area = self.polygon_area(&z[2 * self.n_interior()..]);
        Terms { energy: self.total_area / area * stretch - area, stretch, area, folded, nonzero }
    }

    /// `nabla_x E_S` of vertex `v`: each face adds `2 |f(tau)| / |tau| nabla |f(tau)|`
    /// (`coef` holds the first factor per face), which equals `2 (I_2 (x) L_S(f)) f` of
    /// Eq. 11. Summed over the vertex's corners in face order ([`VertexCorners`]): the same
    /// bits as a scatter face after face, for any thread count.
    #[inline]
    fn vertex_stretch_gradient(&self, x: &[f64], coef: &[f64], v: usize) -> [f64; 2] {
        let (mut gu, mut gv) = (0.0, 0.0);
        for &corner in self.corners.of(v) {
            let (t, a) = (corner as usize / 3, corner as usize % 3);
            let f = self.faces[t];
            let (j, k) = (f[(a + 1) % 3], f[(a + 2) % 3]);
            let c = coef[t];
            // d|f(tau)|/d f_a = 1/2 (y_j - y_k, x_k - x_j)
            gu += c * 0.5 * (x[2 * j + 1] - x[2 * k + 1]);
            gv += c * 0.5 * (x[2 * k] - x[2 * j]);
        }
        [gu, gv]
    }

    /// `nabla_x E_S` per vertex, interleaved (see `vertex_stretch_gradient`).
    pub fn stretch_gradient(&self, x: &[f64]) -> Vec<f64> {
        let mut coef = vec![0.0; self.faces.len()];
        self.stretch_and_coefficients(x, &mut coef);
        let mut grad = vec![0.0; 2 * self.n];
        grad.par_chunks_mut(2).with_min_len(CHUNK).enumerate().for_each(|(v, g)| {
            g.copy_from_slice(&self.vertex_stretch_gradient(x, &coef, v));
        });
        grad
    }

    /// Energy terms and the gradient of the normalized authalic energy in `z` (Eq. 13):
    /// interior `(|S| / A) nabla E_S`; angles through `f_B = (cos theta, sin theta)` plus the
    /// derivatives of `|S| / A` and of `A` (Eq. 13c). One parallel pass over the faces (the
    /// energy and each face's gradient coefficient), one over the vertices.
    pub fn terms_and_gradient(&self, z: &[f64]) -> (Terms, Vec<f64>) {
        let mut g = Vec::new();
        let terms = self.terms_and_gradient_into(z, &mut EvalBuffers::default(), &mut g);
        (terms, g)
    }

    /// [`Self::terms_and_gradient`] with the positions and coefficients in `buf`, the
    /// gradient into `g` (every entry written).
    pub(crate) fn terms_and_gradient_into(&self, z: &[f64], buf: &mut EvalBuffers, g: &mut Vec<f64>) -> Terms {
        let ni = self.n_interior();
        let nb = self.n_boundary();
        self.positions_into(z, &mut buf.x);
        buf.coef.resize(self.faces.len(), 0.0);
        let (x, coef) = (&buf.x, &mut buf.coef);
        let (stretch, folded, nonzero) = self.stretch_and_coefficients(x, coef);
        let coef = &buf.coef;
        let theta = &z[2 * ni..];
        let area = self.polygon_area(theta);
        let s = self.total_area;
        g.resize(self.n_vars(), 0.0);
        let (gi, gb) = g.split_at_mut(2 * ni);
        let (g1, g2) = gi.split_at_mut(ni);
        g1.par_iter_mut().zip(g2).zip(&self.interior).with_min_len(CHUNK).for_each(|((gu, gv), &v)| {
            let [du, dv] = self.vertex_stretch_gradient(x, coef, v);
            *gu = s / area * du;
            *gv = s / area * dv;
        });
        let coef_area = s * stretch / (area * area) + 1.0;
        for (b, (&v, gb)) in self.boundary.iter().zip(gb).enumerate() {
            let th = theta[b];
            let [du, dv] = self.vertex_stretch_gradient(x, coef, v);
            let d_es = -th.sin() * du + th.cos() * dv;
            let (prev, next) = (theta[(b + nb - 1) % nb], theta[(b + 1) % nb]);
            let d_area = 0.5 * ((th - prev).cos() - (next - th).cos());
            *gb = s / area * d_es - coef_area * d_area;
        }
        Terms { energy: s / area * stretch - area, stretch, area, folded, nonzero }
    }

    /// `L_S` values at interleaved image positions `x`, or at the identity map (`None`).
    pub fn laplacian(&self, x: Option<&[f64]>, values: &mut Vec<f64>) {
        let w = match x {
            Some(x) => stretch_weights(&self.faces, &self.area, x, 2),
            None => stretch_weights(&self.faces, &self.area, &self.positions, 3),
        };
        self.pattern.assemble(&w, values);
    }

    /// Area metrics of the map `z`.
    pub fn metrics(&self, z: &[f64]) -> AreaMetrics {
        let x = self.positions_of(z);
        let t = self.terms(z);
        let r: Vec<f64> = (0..self.faces.len())
            .map(|f| (self.image_area(&x, f) / t.area) / (self.area[f] / self.total_area))
            .collect();
        let m = r.len().max(1) as f64;
        let mean = r.iter().sum::<f64>() / m;
        let sd = (r.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m).sqrt();
        let mad = r.iter().map(|v| (v - 1.0).abs()).sum::<f64>() / m;
        AreaMetrics { area_ratio_sd: sd, area_ratio_mad: mad, authalic_energy: t.energy, folded: t.folded }
    }

    /// The initial map of every authalic solver (Algorithm 1, lines 2-7): arc-length boundary
    /// on the unit circle, then `steps` fixed-boundary stretch steps `L_II f_I = -L_IB b`
    /// starting from `L = L_S(id)`, updating `L = L_S(f)` after each. Returns the variables.
    pub fn initial_map(&self, steps: usize) -> Result<Vec<f64>, AuthalicError> {
        let nb = self.n_boundary();
        let p = &self.positions;
        let len = |a: usize, b: usize| (0..3).map(|d| (p[3 * a + d] - p[3 * b + d]).powi(2)).sum::<f64>().sqrt();
        let mut acc = vec![0.0; nb];
        for k in 1..nb {
            acc[k] = acc[k - 1] + len(self.boundary[k - 1], self.boundary[k]);
        }
        let total = acc[nb - 1] + len(self.boundary[nb - 1], self.boundary[0]);
        let theta: Vec<f64> = acc.iter().map(|a| 2.0 * PI * a / total).collect();
        let ni = self.n_interior();
        let mut z = vec![0.0; 2 * ni];
        z.extend(&theta);
        let mut values = Vec::new();
        self.laplacian(None, &mut values);
        let init_err = |what, err| AuthalicError::Init { source_name: self.source.clone(), what, err };
        let mut solver = self.block_solver(&self.block_i).map_err(|e| init_err("analysis of L_II", e))?;
        for _ in 0..steps.max(1) {
            let x = self.positions_of(&z);
            let fi = self.interior_solve(&mut solver, &values, &x).map_err(|e| init_err("L_II solve", e))?;
            z[..2 * ni].copy_from_slice(&fi);
            let x = self.positions_of(&z);
            self.laplacian(Some(&x), &mut values);
        }
        if let Some(i) = z.iter().position(|v| !v.is_finite()) {
            return Err(AuthalicError::InitNotFinite {
                source_name: self.source.clone(),
                what: format!("variable {i}"),
            });
        }
        Ok(z)
    }

    /// `f_I^s = -[L]_II^{-1} [L]_IB f_B^s`, s = 1, 2 (Eq. 14a), as `[f_I^1; f_I^2]`.
    pub(crate) fn interior_solve(
        &self,
        solver: &mut SpdSolver,
        values: &[f64],
        x: &[f64],
    ) -> Result<Vec<f64>, LinearError> {
        solver.factorize(&self.block_i.gather(values), &EXACT)?;
        let mut out = Vec::with_capacity(2 * self.n_interior());
        for d in 0..2 {
            // L_IB f_B = (L f_B-only)_I
            let mut fb = vec![0.0; self.n];
            self.boundary.iter().for_each(|&v| fb[v] = x[2 * v + d]);
            let lf = self.pattern.mul(values, &fb);
            out.extend(self.interior.iter().map(|&v| -lf[v]));
        }
        // Both coordinates in one pass over the factor.
        solver.solve_columns_in_place(&mut out)?;
        Ok(out)
    }
}

/// Solves of `L_II` and `L_BB` are plain (no Jacobi scaling, no shift): `L_S` at a valid map
/// is a Laplacian with a Dirichlet boundary.
pub(super) const EXACT: LinearSettings =
    LinearSettings { tikhonov: 0.0, jacobi: false, ordering: crate::linear::ordering::Ordering::Amd };
