//! `run --resume`: every finished run leaves `runs/<run>.json` with a key of everything that
//! determines its result (code version, task, the config sections that apply, the energy,
//! the solver, and the mesh and handle files' contents). A resumed batch reuses a run whose
//! key matches and whose per-iteration CSV is intact, and runs the others.

use crate::config::LoadedConfig;
use crate::handles::HandleSource;
use crate::output::{SummaryRow, ITERATION_COLUMNS};
use crate::registry::{Dataset, MeshSource};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::authalic::EXTRA_COLUMNS;
use solvers::solver::IterationRecord;
use std::path::{Path, PathBuf};

/// The sidecar of a finished run.
#[derive(Debug, Serialize, Deserialize)]
pub struct Sidecar {
    pub key: String,
    pub summary: SummaryRow,
}

/// 64-bit FNV-1a: stable across builds and platforms (unlike `DefaultHasher`).
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf29ce484222325)
    }

    fn bytes(&mut self, b: &[u8]) -> &mut Fnv {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(0x100000001b3);
        }
        // Separator, so that ("ab", "c") and ("a", "bc") differ.
        self.0 = (self.0 ^ 0xff).wrapping_mul(0x100000001b3);
        self
    }

    fn file(&mut self, path: &Path) -> Result<&mut Fnv> {
        let data = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        Ok(self.bytes(&data))
    }
}

/// The key of one run (hex). `code` identifies the code (version and git revision).
pub fn run_key(cfg: &LoadedConfig, ds: &Dataset, energy: &str, solver: &str, code: &str) -> Result<String> {
    let c = &cfg.config;
    let settings = serde_json::json!({
        "task": c.task,
        "stop": c.stop,
        "line_search": c.line_search,
        "linear": c.linear,
        "init": c.init,
        "energy": c.energy.get(energy),
        "authalic": c.authalic,
        "deform": c.deform,
        "timeout": c.timeout,
    });
    let mut h = Fnv::new();
    h.bytes(code.as_bytes()).bytes(settings.to_string().as_bytes()).bytes(energy.as_bytes()).bytes(solver.as_bytes());
    match &ds.source {
        MeshSource::Generated(g) => h.bytes(b"generated").bytes(g.as_bytes()),
        MeshSource::File(p) => h.bytes(b"file").file(p)?,
    };
    h.bytes(format!("{:?}", ds.expected).as_bytes());
    match &ds.handles {
        HandleSource::None => h.bytes(b"no handles"),
        HandleSource::Generated(g) => h.bytes(b"generated handles").bytes(g.as_bytes()),
        HandleSource::Rule(r) => h.bytes(b"rule").bytes(r.as_bytes()),
        // A missing handles file fails the run anyway: key it by name, not content.
        HandleSource::File { path, set } => match h.bytes(format!("set {set}").as_bytes()).file(path) {
            Ok(h) => h,
            Err(_) => h.bytes(path.display().to_string().as_bytes()),
        },
    };
    Ok(format!("{:016x}", h.0))
}

fn sidecar_path(out_dir: &Path, stem: &str) -> PathBuf {
    out_dir.join("runs").join(format!("{stem}.json"))
}

pub fn write_sidecar(out_dir: &Path, stem: &str, key: &str, summary: &SummaryRow) -> Result<()> {
    let json = serde_json::to_string_pretty(&Sidecar { key: key.to_string(), summary: summary.clone() })?;
    crate::output::write_atomic(&sidecar_path(out_dir, stem), json.as_bytes())
}

/// The finished run `stem` if its sidecar has `key` and its CSV reads back completely.
pub fn previous(out_dir: &Path, stem: &str, key: &str) -> Option<(SummaryRow, Vec<IterationRecord>)> {
    let text = std::fs::read_to_string(sidecar_path(out_dir, stem)).ok()?;
    let side: Sidecar = serde_json::from_str(&text).ok()?;
    if side.key != key {
        return None;
    }
    let rows = read_rows(&out_dir.join("runs").join(format!("{stem}.csv"))).ok()?;
    // A run that finished has its final row; a failed run has none.
    let expected = side.summary.iterations.map_or(0, |i| i + 1);
    (rows.len() == expected).then_some((side.summary, rows))
}

/// Read a per-iteration CSV back into records (the inverse of `output::iteration_csv`).
pub fn read_rows(path: &Path) -> Result<Vec<IterationRecord>> {
    let mut r = csv::Reader::from_path(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let header: Vec<String> = r.headers()?.iter().map(String::from).collect();
    if header.len() < ITERATION_COLUMNS.len() || header[..ITERATION_COLUMNS.len()] != ITERATION_COLUMNS {
        bail!("{}: not a mapbench iteration CSV", path.display());
    }
    let extra_names: Vec<&'static str> = header[ITERATION_COLUMNS.len()..]
        .iter()
        .map(|n| EXTRA_COLUMNS.iter().copied().find(|k| k == n).with_context(|| format!("unknown column {n}")))
        .collect::<Result<_>>()?;
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec?;
        let f = |i: usize| -> Result<f64> { Ok(rec.get(i).unwrap_or("").parse::<f64>()?) };
        let u = |i: usize| -> Result<usize> { Ok(rec.get(i).unwrap_or("").parse::<usize>()?) };
        let mut extra = Vec::with_capacity(extra_names.len());
        for (k, &name) in extra_names.iter().enumerate() {
            extra.push((name, f(ITERATION_COLUMNS.len() + k)?));
        }
        rows.push(IterationRecord {
            iter: u(0)?,
            energy: f(1)?,
            grad_norm: f(3)?,
            step: f(4)?,
            neg_eig: u(5)?,
            indefinite_elems: u(6)?,
            flips: u(7)?,
            t_assemble_s: f(8)?,
            t_project_s: f(9)?,
            t_solve_s: f(10)?,
            t_linesearch_s: f(11)?,
            t_iter_s: f(12)?,
            t_cum_s: f(13)?,
            ls_evals: u(14)?,
            extra,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iteration_csvs_read_back_exactly() {
        let rows = vec![
            IterationRecord {
                iter: 0,
                energy: 3.0,
                grad_norm: 0.1,
                extra: vec![("ascent", 0.0), ("wolfe", f64::NAN)],
                ..Default::default()
            },
            IterationRecord {
                iter: 1,
                energy: 2.0000000000000004,
                step: 1e-20,
                neg_eig: 7,
                t_cum_s: 0.125,
                extra: vec![("ascent", 1.0), ("wolfe", 1.0)],
                ..Default::default()
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        std::fs::write(&p, crate::output::iteration_csv(&rows, 2.0).unwrap()).unwrap();
        let back = read_rows(&p).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[1], rows[1]);
        assert_eq!(back[0].energy, 3.0);
        assert!(back[0].extra[1].1.is_nan());
        std::fs::write(&p, "a,b\n1,2\n").unwrap();
        assert!(read_rows(&p).is_err());
    }

    #[test]
    fn keys_are_stable_hex_and_separate_fields() {
        let mut a = Fnv::new();
        a.bytes(b"ab").bytes(b"c");
        let mut b = Fnv::new();
        b.bytes(b"a").bytes(b"bc");
        assert_ne!(a.0, b.0);
        let mut c = Fnv::new();
        c.bytes(b"ab").bytes(b"c");
        assert_eq!(a.0, c.0);
    }
}
