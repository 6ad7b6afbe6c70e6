//! The line search shared by every Newton-like solver (docs/src/design/numerics.md): the largest
//! orientation-preserving step (Smith and Schaefer 2015; complex-view paper Algorithm 1,
//! line 7), `t0 = min(1, 0.9 t_max)`, then Armijo backtracking (Eq. 1).

use crate::problem::{EnergyScratch, MapProblem};
use rayon::prelude::*;

/// Line search (`[line_search]`), shared by every Newton-like solver.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineSearchSettings {
    /// `t0 = min(1, max_step_fraction * t_max)`.
    pub max_step_fraction: f64,
    /// Armijo constant `c` in `E(x + t d) <= E(x) + c t <g, d>`.
    pub armijo_c: f64,
    /// Backtracking factor.
    pub shrink: f64,
    /// Give up when `t |d| <= min_step`.
    pub min_step: f64,
}

impl Default for LineSearchSettings {
    fn default() -> Self {
        LineSearchSettings { max_step_fraction: 0.9, armijo_c: 0.2, shrink: 0.5, min_step: 1e-12 }
    }
}

/// Smallest positive root of `a t^2 + b t + c` for `c > 0`, `+inf` if there is none.
///
/// Uses the cancellation-free form `q = -(b + sign(b) sqrt(disc)) / 2`, roots `q/a` and
/// `c/q`; `a == 0` is the linear case `b t + c`.
pub fn smallest_positive_root(a: f64, b: f64, c: f64) -> f64 {
    if a == 0.0 {
        return if b < 0.0 { -c / b } else { f64::INFINITY };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let mut best = f64::INFINITY;
    for r in [q / a, if q != 0.0 { c / q } else { f64::INFINITY }] {
        if r > 0.0 && r < best {
            best = r;
        }
    }
    best
}

/// Largest `t` such that every triangle of `x + s d` keeps positive orientation for all
/// `s < t`. Each triangle's doubled signed area is a quadratic in `t`.
pub fn max_injective_step(problem: &MapProblem, x: &[f64], d: &[f64]) -> f64 {
    (0..problem.n_faces())
        .into_par_iter()
        .map(|t| {
            let p = problem.target(x, t);
            let q = problem.target(d, t);
            let (u, v) = ([p[1][0] - p[0][0], p[1][1] - p[0][1]], [p[2][0] - p[0][0], p[2][1] - p[0][1]]);
            let (du, dv) = ([q[1][0] - q[0][0], q[1][1] - q[0][1]], [q[2][0] - q[0][0], q[2][1] - q[0][1]]);
            let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
            let c = cross(u, v);
            let b = cross(u, dv) + cross(du, v);
            let a = cross(du, dv);
            if c <= 0.0 {
                return 0.0;
            }
            smallest_positive_root(a, b, c)
        })
        .reduce(|| f64::INFINITY, f64::min)
}

/// Accepted step of a line search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accepted {
    /// The accepted step length along `d`.
    pub t: f64,
    /// Energy at `x + t d`.
    pub energy: f64,
    /// Energy evaluations spent, the accepted one included.
    pub evals: usize,
}

/// Armijo backtracking from `t0`: accept the first `t` with
/// `E(x + t d) <= E(x) + c t <g, d>`, shrinking `t` until `t |d| <= min_step`.
/// Writes the accepted point into `x_new`; `None` when no step is accepted. `scratch` holds
/// the energy evaluation's buffers across trials and calls.
#[allow(clippy::too_many_arguments)]
pub fn armijo(
    problem: &MapProblem,
    x: &[f64],
    d: &[f64],
    e0: f64,
    g_dot_d: f64,
    t0: f64,
    settings: &LineSearchSettings,
    x_new: &mut Vec<f64>,
    scratch: &mut EnergyScratch,
) -> (Option<Accepted>, usize) {
    let d_norm = crate::problem::norm(d);
    let mut t = t0;
    let mut evals = 0;
    x_new.resize(x.len(), 0.0);
    while t * d_norm > settings.min_step && t > 0.0 {
        for ((xn, xi), di) in x_new.iter_mut().zip(x).zip(d) {
            *xn = xi + t * di;
        }
        let e = problem.energy_with(x_new, scratch);
        evals += 1;
        if e <= e0 + settings.armijo_c * t * g_dot_d {
            return (Some(Accepted { t, energy: e, evals }), evals);
        }
        t *= settings.shrink;
    }
    (None, evals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{EnergyKind, Sd};
    use crate::mesh::Mesh;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn roots_of_hand_made_quadratics() {
        // (t - 2)(t - 3) = t^2 - 5t + 6 -> 2
        assert!(close(smallest_positive_root(1.0, -5.0, 6.0), 2.0));
        // -(t - 4)(t + 1) = -t^2 + 3t + 4 -> 4 (the other root is negative)
        assert!(close(smallest_positive_root(-1.0, 3.0, 4.0), 4.0));
        // (t + 1)(t + 2): both negative -> never degenerates
        assert_eq!(smallest_positive_root(1.0, 3.0, 2.0), f64::INFINITY);
        // no real roots
        assert_eq!(smallest_positive_root(1.0, 0.0, 1.0), f64::INFINITY);
        // double root (t - 1)^2
        assert!(close(smallest_positive_root(1.0, -2.0, 1.0), 1.0));
        // linear: 1 - t/2 -> 2 ; 1 + t -> inf
        assert!(close(smallest_positive_root(0.0, -0.5, 1.0), 2.0));
        assert_eq!(smallest_positive_root(0.0, 1.0, 1.0), f64::INFINITY);
        // tiny quadratic term: accurate near-linear root (no cancellation)
        assert!((smallest_positive_root(1e-18, -1.0, 1.0) - 1.0).abs() < 1e-15);
    }

    fn triangle() -> MapProblem {
        let mesh = Mesh::new("tri", vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]]);
        MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap()
    }

    #[test]
    fn max_step_exact_on_triangles() {
        let pb = triangle();
        let x = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        // move vertex 2 straight down: area (1 - t)/2, linear -> t_max = 1
        let d = [0.0, 0.0, 0.0, 0.0, 0.0, -1.0];
        assert!(close(max_injective_step(&pb, &x, &d), 1.0));
        // collapse vertex 1 and 2 towards each other: u = (1 - t, t), v = (t, 1 - t)
        // cross = (1-t)^2 - t^2 = 1 - 2t -> 0.5 (the t^2 terms cancel: linear case)
        let d = [0.0, 0.0, -1.0, 1.0, 1.0, -1.0];
        assert!(close(max_injective_step(&pb, &x, &d), 0.5));
        // scale up: never degenerates
        let d = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        assert_eq!(max_injective_step(&pb, &x, &d), f64::INFINITY);
        // genuinely quadratic: u = (1, 0) + t(-1, 1), v = (0, 1) + t(0, -2)
        // cross = (1 - t)(1 - 2t) - t * 0 = 2t^2 - 3t + 1 -> 0.5
        let d = [0.0, 0.0, -1.0, 1.0, 0.0, -2.0];
        assert!(close(max_injective_step(&pb, &x, &d), 0.5));
        // just below t_max the triangle is positive, just above it is not
        let t = max_injective_step(&pb, &x, &d);
        for (s, sign) in [(0.999 * t, 1.0), (1.001 * t, -1.0)] {
            let y: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + s * b).collect();
            assert!(crate::local::signed_area(pb.target(&y, 0)) * sign > 0.0);
        }
    }

    #[test]
    fn armijo_accepts_sufficient_decrease_only() {
        let pb = triangle();
        // start from a scaled map: SD decreases towards the isometry
        let x = vec![0.0, 0.0, 2.0, 0.0, 0.0, 2.0];
        let e0 = pb.energy(&x);
        let d = vec![0.0, 0.0, -1.0, 0.0, 0.0, -1.0];
        let mut ev = crate::problem::Evaluation::default();
        pb.evaluate(&x, &mut ev).unwrap();
        let gd: f64 = ev.grad.iter().zip(&d).map(|(a, b)| a * b).sum();
        assert!(gd < 0.0);
        let mut xn = Vec::new();
        let (acc, _) =
            armijo(&pb, &x, &d, e0, gd, 1.0, &LineSearchSettings::default(), &mut xn, &mut Default::default());
        let acc = acc.unwrap();
        assert!(acc.energy <= e0 + 0.2 * acc.t * gd);
        assert!(acc.energy < e0);
        // ascent direction: nothing is accepted
        let up: Vec<f64> = d.iter().map(|v| -v).collect();
        let (acc, evals) =
            armijo(&pb, &x, &up, e0, -gd, 1.0, &LineSearchSettings::default(), &mut xn, &mut Default::default());
        assert!(acc.is_none() && evals > 10);
    }
}
