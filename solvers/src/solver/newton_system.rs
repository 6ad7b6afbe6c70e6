//! The system of a Newton-type step (complex-view paper, Algorithm 1, lines 3-5): the
//! strategy's per-element blocks at the iterate, assembled on the problem's pattern, and
//! the contract of the linear solve that turns it into a direction.

use super::observer::Metric;
use super::observer::SystemView;
use super::stop::StopReason;
use crate::assembly::{pack_lower, Lower6, Pattern};
use crate::hessian::trust_region::{Filter, TrustRegion};
use crate::hessian::trust_region::{FILTER, RHO};
use crate::hessian::SystemBlock;
use crate::linear::LinearSettings;
use crate::problem::{Evaluation, MapProblem};
use crate::smoothness::{self, Matrix8};
use rayon::prelude::*;
use std::time::Instant;

/// Per-element system blocks of `strategy` at the evaluated iterate (parallel; each block
/// depends only on its element), and the smoothness term's edge blocks projected as
/// configured (Section 4.3).
pub fn project_blocks(
    problem: &MapProblem,
    ev: &Evaluation,
    strategy: &dyn SystemBlock,
    blocks: &mut Vec<Lower6>,
    edge_blocks: &mut Vec<Matrix8>,
) {
    let weight = problem.weight();
    blocks.resize(problem.n_faces(), [0.0; 21]);
    blocks.par_iter_mut().zip(ev.states.par_iter()).zip(problem.ops.par_iter()).for_each(|((b, s), op)| {
        *b = pack_lower(&(strategy.block(op, s) * weight));
    });
    if let Some(sm) = &problem.smoothness {
        edge_blocks.resize(sm.pairs.len(), Matrix8::zeros());
        edge_blocks.par_iter_mut().enumerate().for_each(|(k, b)| {
            let [i, j] = sm.pairs[k].faces;
            *b = smoothness::block(sm.coefficient(k), &ev.states[i], &ev.states[j], &sm.ops[k], sm.projection);
        });
    }
}

/// The lower-triangle values of the system matrix on `pattern`: the blocks, the strategy's
/// diagonal shift (SLIM's proximal term) and the handle penalty's diagonal.
pub fn scatter(
    problem: &MapProblem,
    pattern: &Pattern,
    strategy: &dyn SystemBlock,
    blocks: &[Lower6],
    edge_blocks: &[Matrix8],
    values: &mut Vec<f64>,
) {
    pattern.assemble_with_edges(blocks, edge_blocks, values);
    let shift = strategy.diagonal_shift();
    if shift != 0.0 {
        for &p in &pattern.diag {
            values[p] += shift;
        }
    }
    if let Some(pen) = &problem.penalty {
        for (dof, h) in pen.diagonal() {
            values[pattern.diag[dof]] += h;
        }
    }
}

/// The system of a Newton-type step: `strategy`'s per-element blocks at the iterate (or, for
/// an adaptive filter, the blocks of the filter its last model fit chose), assembled on the
/// problem's pattern.
pub(crate) struct SystemBuilder<'a> {
    problem: &'a MapProblem,
    strategy: &'a dyn SystemBlock,
    pub(crate) pattern: Pattern,
    pub(crate) blocks: Vec<Lower6>,
    edge_blocks: Vec<Matrix8>,
    pub(crate) values: Vec<f64>,
    /// An adaptive filter's rule and the filter of the next system.
    trust_region: Option<TrustRegion>,
    filter: Filter,
}

impl<'a> SystemBuilder<'a> {
    pub(crate) fn new(problem: &'a MapProblem, strategy: &'a dyn SystemBlock) -> SystemBuilder<'a> {
        let pattern = problem.system_pattern();
        SystemBuilder {
            problem,
            strategy,
            edge_blocks: vec![Matrix8::zeros(); pattern.edge_scatter.len()],
            blocks: vec![[0.0; 21]; problem.n_faces()],
            pattern,
            values: Vec::new(),
            trust_region: strategy.trust_region(),
            filter: TrustRegion::FIRST,
        }
    }

    /// Build the system at `ev`: the strategy's counters, the projection's and the
    /// scattering's times.
    pub(crate) fn build(&mut self, ev: &Evaluation) -> (Vec<Metric>, f64, f64) {
        let t0 = Instant::now();
        let adaptive = self.trust_region.map(|tr| tr.system(self.filter));
        let system: &dyn SystemBlock = match &adaptive {
            Some(a) => a,
            None => self.strategy,
        };
        project_blocks(self.problem, ev, system, &mut self.blocks, &mut self.edge_blocks);
        let counters = system.counters(&ev.states);
        let t_project = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        scatter(self.problem, &self.pattern, system, &self.blocks, &self.edge_blocks, &mut self.values);
        (counters, t_project, t0.elapsed().as_secs_f64())
    }

    /// After the step `s = t d` from the iterate `ev` (its unfiltered Hessian) with the
    /// energy's `decrease`: an adaptive filter's columns (the filter used, the model fit) and
    /// its choice for the next system; `None` for the other strategies.
    pub(crate) fn fit(
        &mut self,
        ev: &Evaluation,
        d: &[f64],
        t: f64,
        g_dot_d: f64,
        decrease: f64,
    ) -> Option<Vec<Metric>> {
        let tr = self.trust_region?;
        let predicted = -(t * g_dot_d + 0.5 * t * t * self.problem.hessian_form(ev, d));
        let fit = TrustRegion::fit(decrease, predicted, ev.energy);
        let used = self.filter.code();
        self.filter = tr.next(fit);
        Some(vec![(FILTER, used), (RHO, fit)])
    }

    pub(crate) fn view<'v>(&'v self, iter: usize, grad: &'v [f64], linear: &'v LinearSettings) -> SystemView<'v> {
        SystemView {
            iter,
            col_ptr: &self.pattern.col_ptr,
            row_idx: &self.pattern.row_idx,
            diag: &self.pattern.diag,
            values: &self.values,
            grad,
            linear,
        }
    }
}

/// How a Newton-type step solves its assembled system for the direction.
pub(crate) trait Direction {
    /// The direction `d` for the system in `system` at `ev` (gradient norm `grad_norm`),
    /// iterate `iter`: the shift of the system solved and the method's own values, by column.
    fn direction(
        &mut self,
        system: &SystemBuilder,
        ev: &Evaluation,
        grad_norm: f64,
        iter: usize,
        d: &mut Vec<f64>,
    ) -> Result<(f64, Vec<Metric>), StopReason>;
}
