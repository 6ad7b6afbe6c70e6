//! The Newton system of a parameterization at an iterate, as the solvers build it, for
//! exporting (`mapbench export-system`) and timing other sparse solvers on the same matrix
//! (`scripts/bench_linear_solvers.py`).

use crate::energy::EnergyKind;
use crate::linear::regularize;
use crate::mesh::Mesh;
use crate::problem::Evaluation;
use crate::solver::newton_system::{project_blocks, scatter};
use crate::solver::{StopAt, SystemView};
use crate::tasks::catalogue::lookup;
use crate::tasks::map_task::{map_problem, MapError};
use crate::tasks::param::{solve_param_with, ParamSettings};
use crate::tasks::Task;
use std::fmt::Write as _;

/// A symmetric system `A d = b` with `A` as its lower triangle in CSC form.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonSystem {
    /// Number of unknowns (two per vertex).
    pub n: usize,
    /// Start of each column in `row_idx` and `values` (`n + 1` entries).
    pub col_ptr: Vec<usize>,
    /// Row of each stored entry.
    pub row_idx: Vec<usize>,
    /// Value of each stored entry, shifted and scaled as factorized.
    pub values: Vec<f64>,
    /// The right-hand side `-S grad`, scaled to match.
    pub rhs: Vec<f64>,
    /// The iteration the system belongs to (0 = the initial map).
    pub iteration: usize,
}

/// Run `solver` on the `param` task until `iteration` and return the system it factorizes
/// next: the projected matrix after the Tikhonov shift and Jacobi scaling of
/// `settings.solver.linear` ([`crate::linear::regularize`]; SPD, unlike the raw matrix, whose
/// kernel holds the translations), and the right-hand side scaled to match, `-S grad`.
/// `sd_min` is the SD minimum of a chained start, as the run is given it
/// ([`crate::tasks::param::solve_param_with`]).
pub fn param_system(
    mesh: &Mesh,
    energy: EnergyKind,
    solver: &str,
    settings: &ParamSettings,
    sd_min: Option<&[f64]>,
    iteration: usize,
) -> Result<NewtonSystem, MapError> {
    let out = solve_param_with(mesh, energy, solver, settings, sd_min, &mut StopAt(iteration))?;
    let spec = lookup(solver, Task::Param)?.newton_spec(Task::Param, &energy, &settings.solver.options)?;
    let mesh = mesh.normalized();
    // The run's own problem, smoothness term included: the matrix it factorizes.
    let problem = map_problem(&mesh, energy, spec.smoothness_projection, settings.smoothness)?;
    let mut ev = Evaluation::default();
    problem
        .evaluate(&out.x, &mut ev)
        .map_err(|e| MapError::Energy(format!("{}: iterate {}: {e}", mesh.source, out.iterations)))?;
    let pattern = problem.system_pattern();
    let (mut blocks, mut edge_blocks, mut values) = (Vec::new(), Vec::new(), Vec::new());
    project_blocks(&problem, &ev, spec.block.as_ref(), &mut blocks, &mut edge_blocks);
    scatter(&problem, &pattern, spec.block.as_ref(), &blocks, &edge_blocks, &mut values);
    let (mut scaled, mut scale) = (Vec::new(), Vec::new());
    regularize(
        &pattern.col_ptr,
        &pattern.row_idx,
        &pattern.diag,
        &values,
        &settings.solver.linear,
        &mut scaled,
        &mut scale,
    )
    .map_err(|e| MapError::Energy(format!("{}: iterate {}: {e}", mesh.source, out.iterations)))?;
    Ok(NewtonSystem {
        n: pattern.n,
        col_ptr: pattern.col_ptr.clone(),
        row_idx: pattern.row_idx.clone(),
        values: scaled,
        rhs: ev.grad.iter().zip(&scale).map(|(g, s)| -g * s).collect(),
        iteration: out.iterations,
    })
}

impl NewtonSystem {
    /// The system a solver reported to [`crate::solver::Observer::system`], shifted and scaled as its
    /// factorization does ([`regularize`]).
    pub fn from_view(view: &SystemView) -> Result<NewtonSystem, crate::linear::LinearError> {
        let (mut values, mut scale) = (Vec::new(), Vec::new());
        regularize(view.col_ptr, view.row_idx, view.diag, view.values, view.linear, &mut values, &mut scale)?;
        Ok(NewtonSystem {
            n: view.diag.len(),
            col_ptr: view.col_ptr.to_vec(),
            row_idx: view.row_idx.to_vec(),
            values,
            rhs: view.grad.iter().zip(&scale).map(|(g, s)| -g * s).collect(),
            iteration: view.iter,
        })
    }

    /// The matrix as Matrix Market (`coordinate real symmetric`, lower triangle, 1-based).
    pub fn matrix_market(&self) -> String {
        let mut s = format!(
            "%%MatrixMarket matrix coordinate real symmetric\n% mapbench Newton system, iteration {}\n{} {} {}\n",
            self.iteration,
            self.n,
            self.n,
            self.values.len()
        );
        for c in 0..self.n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let _ = writeln!(s, "{} {} {:?}", self.row_idx[p] + 1, c + 1, self.values[p]);
            }
        }
        s
    }

    /// The right-hand side as a Matrix Market dense column.
    pub fn rhs_matrix_market(&self) -> String {
        let mut s = format!("%%MatrixMarket matrix array real general\n{} 1\n", self.n);
        for v in &self.rhs {
            let _ = writeln!(s, "{v:?}");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::Sd;
    use crate::linear::ordering::Ordering;
    use crate::linear::{LinearSettings, SpdSolver};
    use crate::tasks::param::solve_param;

    /// Keeps the system the solver factorizes at iteration `k`, then stops it.
    struct Capture {
        k: usize,
        system: Option<NewtonSystem>,
    }

    impl crate::solver::Observer for Capture {
        fn observe(&mut self, _: &crate::solver::IterationRecord) -> crate::solver::Flow {
            if self.system.is_some() {
                crate::solver::Flow::Stop
            } else {
                crate::solver::Flow::Continue
            }
        }
        fn system(&mut self, view: &SystemView) {
            if view.iter == self.k {
                self.system = Some(NewtonSystem::from_view(view).unwrap());
            }
        }
    }

    /// `param_system` rebuilds exactly the matrix and right-hand side the run factorizes,
    /// with the smoothness term (whose edge blocks change the pattern) and without it.
    #[test]
    fn the_exported_system_is_bit_for_bit_the_one_the_run_factorizes() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let e = EnergyKind::Sd(Sd);
        let mut smooth = ParamSettings::for_energy(&e);
        smooth.smoothness = Some((0.25, crate::smoothness::Projection::Analytic));
        let mut nnz = Vec::new();
        for (settings, k) in [(ParamSettings::for_energy(&e), 0), (smooth.clone(), 0), (smooth, 2)] {
            let mut run = Capture { k, system: None };
            solve_param(&mesh, e, "kp-newton", &settings, &mut run).unwrap();
            let exported = param_system(&mesh, e, "kp-newton", &settings, None, k).unwrap();
            assert_eq!(Some(&exported), run.system.as_ref(), "iteration {k}");
            nnz.push(exported.values.len());
        }
        // the smoothness term couples the vertices opposite each interior edge
        assert!(nnz[1] > nnz[0] * 3 / 2, "{nnz:?}");
    }

    #[test]
    fn the_exported_system_is_the_one_newton_solves() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let e = EnergyKind::Sd(Sd);
        let settings = ParamSettings::for_energy(&e);
        let sys = param_system(&mesh, e, "kp-newton", &settings, None, 2).unwrap();
        assert_eq!(sys.iteration, 2);
        assert_eq!(sys.n, 2 * mesh.n_vertices());
        // the Newton direction from this system decreases the energy (descent), and the
        // Matrix Market text has one line per stored entry after the 3 header lines
        let pattern_diag: Vec<usize> =
            (0..sys.n).map(|c| (sys.col_ptr[c]..sys.col_ptr[c + 1]).find(|&p| sys.row_idx[p] == c).unwrap()).collect();
        let mut lin = SpdSolver::from_csc(sys.n, sys.col_ptr.clone(), sys.row_idx.clone(), pattern_diag).unwrap();
        let d = lin
            .solve(&sys.values, &sys.rhs, &LinearSettings { ordering: Ordering::Amd, ..Default::default() })
            .unwrap();
        let g_dot_d: f64 = sys.rhs.iter().zip(&d).map(|(b, d)| -b * d).sum();
        assert!(g_dot_d < 0.0);
        let mm = sys.matrix_market();
        assert_eq!(mm.lines().count(), 3 + sys.values.len());
        assert!(mm.starts_with("%%MatrixMarket matrix coordinate real symmetric"));
        assert_eq!(sys.rhs_matrix_market().lines().count(), 2 + sys.n);
    }

    /// With a smoothness term the exported system is that of the run's problem: the edge
    /// blocks widen the pattern and the term enters the right-hand side.
    #[test]
    fn the_exported_system_carries_the_smoothness_term() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let e = EnergyKind::Sd(Sd);
        let plain = param_system(&mesh, e, "kp-newton", &ParamSettings::for_energy(&e), None, 0).unwrap();
        let settings = ParamSettings {
            smoothness: Some((0.25, crate::smoothness::Projection::Analytic)),
            ..ParamSettings::for_energy(&e)
        };
        let smooth = param_system(&mesh, e, "kp-newton", &settings, None, 0).unwrap();
        assert_eq!((smooth.n, smooth.iteration), (plain.n, 0));
        assert!(smooth.values.len() > plain.values.len());
        assert_ne!(smooth.rhs, plain.rhs);
    }
}
