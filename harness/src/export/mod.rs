//! `export-system CONFIG`: the Newton system of each selected `param` run at a given
//! iteration, as Matrix Market files, so other sparse solvers can be timed on exactly the
//! matrices mapbench factorizes (`scripts/bench_linear_solvers.py`).

pub mod maps;

use crate::plan::config::LoadedConfig;
use crate::plan::{Plan, RunSettings, Task};
use crate::run_folder::write_atomic;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Write `<out>/<run>__it<K>.mtx` (lower triangle, symmetric) and `<run>__it<K>.rhs.mtx` for
/// every run of the plan, with the settings `run` solves it with. Returns the matrix files. A run that stops before
/// iteration `K` exports the system at its last iterate (named by that iteration).
pub fn export_systems(plan: &Plan, iteration: usize, out: &Path) -> Result<Vec<PathBuf>> {
    check_task(&plan.config)?;
    let mut written = Vec::new();
    for r in &plan.runs {
        let RunSettings::Param { energy, settings } = &r.settings else {
            bail!("run {}: not a param run", r.stem);
        };
        let mesh = plan.dataset(r).load()?;
        // A chained start is the run's: the stored SD minimum (computed and stored if missing).
        let notice = |line: &str| eprintln!("{line}");
        crate::judge::reference::chained::resolve(plan, r, None, &notice, &AtomicBool::new(false))?;
        let sd_min = plan.starts.of(plan, r).transpose().map_err(|e| anyhow::anyhow!("run {}: {e}", r.stem))?;
        let sys = solvers::tasks::system::param_system(
            &mesh,
            *energy,
            &r.solver,
            settings,
            sd_min.as_deref().map(|x| &x[..]),
            iteration,
        )
        .with_context(|| format!("run {}", r.stem))?;
        let path = out.join(format!("{}__it{}.mtx", r.stem, sys.iteration));
        write_atomic(&path, sys.matrix_market().as_bytes())?;
        write_atomic(&path.with_extension("rhs.mtx"), sys.rhs_matrix_market().as_bytes())?;
        eprintln!("{}: n = {}, {} stored entries", path.display(), sys.n, sys.values.len());
        written.push(path);
    }
    Ok(written)
}

/// export-system writes the systems of `param` runs only.
pub fn check_task(cfg: &LoadedConfig) -> Result<()> {
    if cfg.config.task != Task::Param {
        bail!("{}: export-system supports task = \"param\"", cfg.path.display());
    }
    Ok(())
}

/// A system read back from the files [`export_systems`] writes.
pub struct SystemFile {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

/// Read a `coordinate real symmetric` Matrix Market file (lower triangle) into CSC.
pub fn read_matrix_market(path: &Path) -> Result<SystemFile> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.starts_with('%'));
    let (_, size) = lines.next().with_context(|| format!("{}: no size line", path.display()))?;
    let dims: Vec<usize> = size
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .with_context(|| format!("{}: size line", path.display()))?;
    let [n, m, nnz] = dims[..] else { bail!("{}: size line needs rows, columns, entries", path.display()) };
    if n != m {
        bail!("{}: not square ({n} x {m})", path.display());
    }
    let mut entries: Vec<(usize, usize, f64)> = Vec::with_capacity(nnz);
    for (i, line) in lines {
        let bad = || format!("{}: line {}: expected `row col value`", path.display(), i + 1);
        let mut t = line.split_whitespace();
        let (r, c, v) = (t.next(), t.next(), t.next());
        let (Some(r), Some(c), Some(v)) = (r, c, v) else { bail!(bad()) };
        let (r, c, v): (usize, usize, f64) =
            (r.parse().with_context(bad)?, c.parse().with_context(bad)?, v.parse().with_context(bad)?);
        if r < c || r == 0 || r > n {
            bail!("{}: line {}: entry ({r}, {c}) is not in the lower triangle", path.display(), i + 1);
        }
        entries.push((c - 1, r - 1, v));
    }
    if entries.len() != nnz {
        bail!("{}: {} entries, the size line says {nnz}", path.display(), entries.len());
    }
    entries.sort_by_key(|&(c, r, _)| (c, r));
    let mut col_ptr = vec![0; n + 1];
    for &(c, _, _) in &entries {
        col_ptr[c + 1] += 1;
    }
    for c in 0..n {
        col_ptr[c + 1] += col_ptr[c];
    }
    Ok(SystemFile {
        n,
        col_ptr,
        row_idx: entries.iter().map(|e| e.1).collect(),
        values: entries.iter().map(|e| e.2).collect(),
    })
}

/// Median times in milliseconds of mapbench's own sparse Cholesky on a system file.
#[derive(Debug, serde::Serialize)]
pub struct Timing {
    pub n: usize,
    pub ordering: &'static str,
    pub analyse_ms: f64,
    pub factorize_ms: f64,
    pub solve_ms: f64,
    pub factor_entries: usize,
    /// The rayon threads the factorization and solve ran on.
    pub threads: usize,
    /// `subtree` (mapbench's parallel factorization) or `faer` (faer's own kernel).
    pub kernel: &'static str,
}

/// Analyse once, then factorize and solve `repeat` times (no Jacobi scaling or shift: the
/// matrix as written), as `scripts/bench_linear_solvers.py` times the other solvers.
pub fn time_system(
    sys: &SystemFile,
    ordering: solvers::linear::ordering::Ordering,
    repeat: usize,
    faer_kernel: bool,
) -> Result<Timing> {
    use solvers::linear::{LinearSettings, SpdSolver};
    use std::time::Instant;
    let diag: Vec<usize> = (0..sys.n)
        .map(|c| {
            (sys.col_ptr[c]..sys.col_ptr[c + 1])
                .find(|&p| sys.row_idx[p] == c)
                .with_context(|| format!("column {c} has no diagonal entry"))
        })
        .collect::<Result<_>>()?;
    let block = if sys.n.is_multiple_of(2) { 2 } else { 1 };
    let t0 = Instant::now();
    let mut lin = SpdSolver::from_csc_ordered(sys.n, sys.col_ptr.clone(), sys.row_idx.clone(), diag, ordering, block)?;
    let analyse_ms = 1e3 * t0.elapsed().as_secs_f64();
    lin.set_faer_kernel(faer_kernel);
    let settings = LinearSettings { tikhonov: 0.0, jacobi: false, ordering };
    let b = vec![1.0; sys.n];
    let (mut fact, mut solve) = (Vec::new(), Vec::new());
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        lin.factorize(&sys.values, &settings)?;
        fact.push(1e3 * t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        lin.solve_factored(&b)?;
        solve.push(1e3 * t0.elapsed().as_secs_f64());
    }
    Ok(Timing {
        n: sys.n,
        ordering: lin.ordering().as_str(),
        analyse_ms,
        factorize_ms: crate::stats::median(&mut fact).unwrap_or(f64::NAN),
        solve_ms: crate::stats::median(&mut solve).unwrap_or(f64::NAN),
        factor_entries: lin.factor_len(),
        threads: rayon::current_num_threads(),
        kernel: if faer_kernel { "faer" } else { "subtree" },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use solvers::solver::{Flow, IterationRecord, Observer, SystemView};
    use solvers::tasks::system::NewtonSystem;

    /// Keeps the first system a run factorizes, then stops it.
    #[derive(Default)]
    struct FirstSystem(Option<NewtonSystem>);

    impl Observer for FirstSystem {
        fn observe(&mut self, _: &IterationRecord) -> Flow {
            if self.0.is_some() {
                Flow::Stop
            } else {
                Flow::Continue
            }
        }
        fn system(&mut self, view: &SystemView) {
            self.0.get_or_insert_with(|| NewtonSystem::from_view(view).unwrap());
        }
    }

    /// `export-system` on a config with the smoothness term writes the matrix `run`
    /// factorizes: the plan's run, solved with the settings `run` uses, reports its first
    /// system, and the exported file holds exactly that (before the plan, export-system
    /// dropped the term and wrote a matrix of another pattern).
    #[test]
    fn the_exported_matrix_is_the_runs_own_first_system_smoothness_included() {
        let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/export-test.toml");
        let text = "name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n\
                    [energy.sd]\nsmoothness = 0.25\n";
        let plan = Plan::resolve(LoadedConfig::parse(text, &cfg).unwrap(), &[]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files = export_systems(&plan, 0, dir.path()).unwrap();
        let exported = read_matrix_market(&files[0]).unwrap();
        let run = &plan.runs[0];
        let RunSettings::Param { energy, settings } = &run.settings else { panic!("{run:?}") };
        assert!(settings.smoothness.is_some());
        let mesh = plan.dataset(run).load().unwrap();
        let mut first = FirstSystem::default();
        solvers::tasks::param::solve_param(&mesh, *energy, &run.solver, settings, &mut first).unwrap();
        let own = first.0.unwrap();
        assert_eq!((exported.n, &exported.col_ptr, &exported.row_idx), (own.n, &own.col_ptr, &own.row_idx));
        assert_eq!(exported.values, own.values);
        // without the term the pattern is another one
        let plain = solvers::tasks::param::ParamSettings { smoothness: None, ..settings.clone() };
        let other = solvers::tasks::system::param_system(&mesh, *energy, &run.solver, &plain, None, 0).unwrap();
        assert!(other.values.len() < own.values.len(), "{} vs {}", other.values.len(), own.values.len());
    }
}
