//! `run --resume`: every finished run leaves `runs/<run>.json` with a key of everything that
//! determines its result (code version, task, the config sections that apply, the energy,
//! the solver, and the mesh and handle files' contents). A resumed batch reuses a run whose
//! key matches and whose files (per-iteration CSV, map) are intact, and runs the others.

use crate::config::LoadedConfig;
use crate::handles::HandleSource;
use crate::output::{csv_error, read_csv_bytes, run_stem, SummaryRow, ITERATION_COLUMNS};
use crate::registry::{Dataset, MeshSource};
use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
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

pub(crate) fn sidecar_path(out_dir: &Path, stem: &str) -> PathBuf {
    out_dir.join("runs").join(format!("{stem}.json"))
}

pub fn write_sidecar(out_dir: &Path, stem: &str, key: &str, summary: &SummaryRow) -> Result<()> {
    let json = serde_json::to_string_pretty(&Sidecar { key: key.to_string(), summary: summary.clone() })?;
    crate::output::write_atomic(&sidecar_path(out_dir, stem), json.as_bytes())
}

/// The finished run `stem` if its sidecar has `key` and all its files are intact: the CSV
/// reads back completely and, for a run that produced a map (every run with iterations,
/// see `runner::run_one`), `uv/<stem>.obj` reads back too. Otherwise the run runs again.
pub fn previous(out_dir: &Path, stem: &str, key: &str) -> Option<(SummaryRow, Vec<IterationRecord>)> {
    let text = std::fs::read_to_string(sidecar_path(out_dir, stem)).ok()?;
    let side: Sidecar = serde_json::from_str(&text).ok()?;
    if side.key != key {
        return None;
    }
    let rows = read_rows(&out_dir.join("runs").join(format!("{stem}.csv"))).ok()?;
    // A run that finished has its final row; a failed run has none.
    let expected = side.summary.iterations.map_or(0, |i| i + 1);
    if rows.len() != expected {
        return None;
    }
    if side.summary.iterations.is_some() {
        crate::mapfile::read(&out_dir.join("uv").join(format!("{stem}.obj"))).ok()?;
    }
    Some((side.summary, rows))
}

/// A per-iteration CSV read back: its rows and, per row, its `energy_minus_best` as written
/// (the plots draw that column; recomputing it would not round the same way).
#[derive(Debug)]
pub struct IterationFile {
    pub rows: Vec<IterationRecord>,
    pub energy_minus_best: Vec<f64>,
}

/// Read a per-iteration CSV back into records (the inverse of `output::iteration_csv`).
pub fn read_rows(path: &Path) -> Result<Vec<IterationRecord>> {
    Ok(read_iterations(path)?.rows)
}

/// The one reader of per-iteration CSVs (resume, report, plots), columns by header name.
/// Every error names the file and the line, and the column of a bad cell.
pub fn read_iterations(path: &Path) -> Result<IterationFile> {
    let bytes = read_csv_bytes(path)?;
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header = r.headers().map_err(|e| csv_error(path, None, None, &e))?.clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("{}: line 1: no column `{name}`: not a mapbench iteration CSV", path.display()))
    };
    let cols: Vec<usize> = ITERATION_COLUMNS.iter().map(|n| col(n)).collect::<Result<_>>()?;
    // The columns after the design ones are a solver's extras; `fill_best` rewrites the file
    // from the records, so a column they cannot hold is refused rather than dropped.
    let mut extra_cols: Vec<(&'static str, usize)> = Vec::new();
    for (j, name) in header.iter().enumerate().filter(|(_, n)| !ITERATION_COLUMNS.contains(n)) {
        let known = solvers::solver::catalogue::extra_column(name);
        let known = known.with_context(|| format!("{}: line 1: unknown column `{name}`", path.display()))?;
        extra_cols.push((known, j));
    }
    let mut out = IterationFile { rows: Vec::new(), energy_minus_best: Vec::new() };
    for rec in r.records() {
        let rec = rec.map_err(|e| csv_error(path, Some(&header), None, &e))?;
        let line = rec.position().map_or(0, |p| p.line());
        let cell = |k: usize| {
            let j = cols[k];
            (j, rec.get(j).unwrap_or(""))
        };
        let bad = |j: usize, text: &str, what: &str| {
            anyhow!("{}: line {line}: column {} `{}`: `{text}` is not {what}", path.display(), j + 1, &header[j])
        };
        let f = |k: usize| -> Result<f64> {
            let (j, text) = cell(k);
            text.parse().map_err(|_| bad(j, text, "a number"))
        };
        let u = |k: usize| -> Result<usize> {
            let (j, text) = cell(k);
            text.parse().map_err(|_| bad(j, text, "a count"))
        };
        let mut extra = Vec::with_capacity(extra_cols.len());
        for &(name, j) in &extra_cols {
            let text = rec.get(j).unwrap_or("");
            extra.push((name, text.parse().map_err(|_| bad(j, text, "a number"))?));
        }
        out.energy_minus_best.push(f(2)?);
        out.rows.push(IterationRecord {
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
    Ok(out)
}

/// The per-iteration CSV of the run `s` in `run_dir`, refused unless it has the row of every
/// iteration the summary counts (a file cut at a row boundary still parses).
pub fn read_run(run_dir: &Path, s: &SummaryRow) -> Result<IterationFile> {
    let path = run_dir.join("runs").join(format!("{}.csv", run_stem(&s.dataset, &s.energy, &s.solver)));
    let file = read_iterations(&path)?;
    if let Some(n) = s.iterations {
        // Iteration 0 (the initial state) has a row too.
        if file.rows.len() != n + 1 {
            bail!(
                "{}: {} rows, but summary.csv says {n} iterations, which is {} rows with iteration 0: \
                 the file is incomplete or not this run's",
                path.display(),
                file.rows.len(),
                n + 1
            );
        }
    }
    Ok(file)
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
    fn corrupt_iteration_csvs_are_refused_by_file_line_and_column() {
        let rows: Vec<IterationRecord> =
            (0..3).map(|i| IterationRecord { iter: i, energy: 3.0 - i as f64, ..Default::default() }).collect();
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("runs")).unwrap();
        let p = dir.path().join("runs/m__sd__cm.csv");
        let good = String::from_utf8(crate::output::iteration_csv(&rows, 1.0).unwrap()).unwrap();
        let err = |text: &[u8]| {
            std::fs::write(&p, text).unwrap();
            let e = format!("{:#}", read_iterations(&p).unwrap_err());
            assert!(e.starts_with(&format!("{}: ", p.display())), "{e}");
            e
        };
        // cut mid-row: the last cell would still parse
        assert!(err(&good.as_bytes()[..good.len() - 1]).contains("line 4: the row has no line end"));
        let lines: Vec<&str> = good.lines().collect();
        assert!(err(format!("{}\n{}\n0,1\n", lines[0], lines[1]).as_bytes()).contains("line 3: 2 cells"));
        let e = err(good.replacen("\n1,2.0,", "\n1,two,", 1).as_bytes());
        assert!(e.contains("line 3: column 2 `energy`: `two` is not a number"), "{e}");
        let e = err(good.replacen("\n2,1.0,", "\n-2,1.0,", 1).as_bytes());
        assert!(e.contains("line 4: column 1 `iter`: `-2` is not a count"), "{e}");
        assert!(err(b"\xff\xfe,\x00\n\x80\n").contains("line 1: column 1: not UTF-8 text"));
        assert!(err(good.replace("t_cum_s", "t_total").as_bytes()).contains("line 1: no column `t_cum_s`"));
        assert!(err(good.replace("ls_evals", "ls_evals,x").as_bytes()).contains("line 1: unknown column `x`"));
        // columns are found by name, and energy_minus_best is kept as written
        std::fs::write(&p, &good).unwrap();
        let file = read_iterations(&p).unwrap();
        assert_eq!(file.rows, rows);
        assert_eq!(file.energy_minus_best, vec![2.0, 1.0, 0.0]);
        // a file cut at a row boundary parses, but not as the run the summary counts
        let summary = SummaryRow {
            dataset: "m".into(),
            energy: "sd".into(),
            solver: "cm".into(),
            iterations: Some(2),
            ..Default::default()
        };
        assert_eq!(read_run(dir.path(), &summary).unwrap().rows.len(), 3);
        std::fs::write(&p, lines[..3].join("\n") + "\n").unwrap();
        let e = format!("{:#}", read_run(dir.path(), &summary).unwrap_err());
        assert!(e.contains("m__sd__cm.csv: 2 rows, but summary.csv says 2 iterations, which is 3 rows"), "{e}");
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
