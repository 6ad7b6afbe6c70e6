//! Resolving chained starts (`crate::plan::starts`): the SD minimum a run with
//! `start = "sd-minimum"` starts from is the SD problem's reference minimum, looked up in the
//! stores or computed and stored like any other, so a nightly computes it once and every batch
//! starts from the same map; without a store it is `solvers::tasks::param::sd_minimum`. The book's
//! numerics page, "Starts", says why.

use super::store::Book;
use crate::judge::problem::Problem;
use crate::plan::starts::{memo_key, sd_problem};
use crate::plan::{Plan, PlannedRun, RunSettings};
use anyhow::{Context, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Resolve the chained start of `run` (nothing to do without one) into the plan's memo, once
/// per batch, looking the SD reference up in `book` (the caller's, so that a reference it
/// computes is the batch's too; `None`: the plan's stores) and adding it there when computed:
/// `notice` says so, and the computation stops when `interrupt` is set. The error names the
/// dataset and why.
pub fn resolve(
    plan: &Plan,
    run: &PlannedRun,
    book: Option<&mut Book>,
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<()> {
    resolve_with(plan, run, Lookup { book, compute: true, notice, interrupt }).map(|_| ())
}

/// Whether the chained start of `run` is in `book` (resolved then), without computing it:
/// what [`super::missing`] counts. `true` for a run without a chained start, and for one whose
/// SD problem cannot be made (its runs fail on their own).
pub fn stored(plan: &Plan, run: &PlannedRun, book: &mut Book) -> bool {
    let lookup = Lookup { book: Some(book), compute: false, notice: &|_| {}, interrupt: &AtomicBool::new(false) };
    !matches!(resolve_with(plan, run, lookup), Ok(false))
}

/// Where an SD reference is looked for and whether a missing one is computed.
struct Lookup<'a> {
    /// The caller's book; `None`: the plan's stores.
    book: Option<&'a mut Book>,
    compute: bool,
    notice: &'a dyn Fn(&str),
    interrupt: &'a AtomicBool,
}

/// [`resolve`], computing a missing SD reference only when `lookup.compute`; `Ok(false)` when
/// it is missing and not computed.
fn resolve_with(plan: &Plan, run: &PlannedRun, lookup: Lookup) -> Result<bool> {
    let interrupt = lookup.interrupt;
    let Some(sd) = sd_problem(plan, run) else { return Ok(true) };
    let key = memo_key(plan, &sd);
    let mut memo = plan.starts.lock();
    let resolved = match memo.get(&key) {
        Some(r) => r.clone(),
        None => match sd_minimum(plan, &sd, lookup) {
            Ok(None) => return Ok(false),
            found => {
                let r = found.map(|x| Arc::new(x.unwrap_or_default())).map_err(|e| format!("{e:#}"));
                if !interrupt.load(Ordering::Relaxed) {
                    memo.insert(key, r.clone());
                }
                r
            }
        },
    };
    let dataset = &plan.dataset(run).name;
    resolved.map(|_| true).map_err(|e| anyhow::anyhow!("{dataset}: the sd-minimum start: {e}"))
}

/// The reference minimum of the SD problem `sd`: looked up in `book` (or the plan's stores),
/// or (when `compute`) computed and added there; `None` when missing and not computed.
fn sd_minimum(plan: &Plan, sd: &PlannedRun, lookup: Lookup) -> Result<Option<Vec<f64>>> {
    let Lookup { book, compute, notice, interrupt } = lookup;
    let problem = Problem::of(plan, sd)?;
    let dataset = plan.dataset(sd).name.clone();
    let mut opened;
    let book = match (book, &plan.references) {
        (Some(b), _) => b,
        (None, Some(stores)) => {
            opened = Book::open(stores)?;
            &mut opened
        }
        (None, None) => {
            let RunSettings::Param { settings, .. } = &sd.settings else {
                anyhow::bail!("{dataset}: not a param problem")
            };
            return Ok(compute
                .then(|| solvers::tasks::param::sd_minimum(&problem.mesh.normalized(), settings))
                .transpose()?);
        }
    };
    let key = super::entry::key(plan, sd)?;
    if let Some((_, x, _)) = super::store::lookup(book, &key, &problem, notice) {
        return Ok(Some(x));
    }
    if !compute {
        return Ok(None);
    }
    anyhow::ensure!(!interrupt.load(Ordering::Relaxed), "interrupted before the SD minimum was computed");
    let name = format!("{dataset} param sd");
    notice(&format!("reference minimum of {name}: computing (the sd-minimum start of {dataset})"));
    let step = |line: &str| notice(&format!("reference minimum of {name}: {line}"));
    let (r, x) = super::computation::compute(&problem, &key, &dataset, "sd", &step, interrupt)?;
    notice(&format!("reference minimum of {name}: E* = {:.12} (|grad| {:.1e})", r.e_star, r.grad_norm));
    book.add(r, &x, &problem.mesh).context("adding the computed SD reference")?;
    Ok(Some(x))
}
