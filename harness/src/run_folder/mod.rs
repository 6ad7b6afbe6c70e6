//! CSV files of a run (design.md "Output of a run"): one per-iteration file per run and
//! `summary.csv`, with exactly the documented columns. Files are written atomically
//! (temporary file + rename) so an interrupted batch never leaves a half-written run.

pub mod map;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use solvers::solver::IterationRecord;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Per-iteration CSV columns, in design.md order; `ls_evals` follows as an extra.
pub const ITERATION_COLUMNS: [&str; 15] = [
    "iter",
    "energy",
    "energy_minus_best",
    "grad_norm",
    "step",
    "neg_eig",
    "indefinite_elems",
    "flips",
    "t_assemble_s",
    "t_project_s",
    "t_solve_s",
    "t_linesearch_s",
    "t_iter_s",
    "t_cum_s",
    "ls_evals",
];

/// `summary.csv` columns, in design.md order; `area_ratio_sd` .. `folded` are filled by
/// `authalic` runs, `analysis_s` and `analysis_shared` by the Newton-type solvers.
pub const SUMMARY_COLUMNS: [&str; 26] = [
    "dataset",
    "task",
    "energy",
    "solver",
    "vertices",
    "faces",
    "iterations",
    "converged",
    "stop_reason",
    "init_energy",
    "final_energy",
    "grad_norm",
    "time_s",
    "ms_per_vertex",
    "iter_ms_median",
    "project_ms_median",
    "solve_ms_median",
    "flips",
    "status",
    "error",
    "area_ratio_sd",
    "area_ratio_mad",
    "authalic_energy",
    "folded",
    "analysis_s",
    "analysis_shared",
];

#[derive(Clone, Debug, Serialize)]
struct IterationRow {
    iter: usize,
    energy: f64,
    energy_minus_best: f64,
    grad_norm: f64,
    step: f64,
    neg_eig: usize,
    indefinite_elems: usize,
    flips: usize,
    t_assemble_s: f64,
    t_project_s: f64,
    t_solve_s: f64,
    t_linesearch_s: f64,
    t_iter_s: f64,
    t_cum_s: f64,
    ls_evals: usize,
}

/// One row of `summary.csv`. Fields unknown for a failed run are empty.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    pub dataset: String,
    pub task: String,
    pub energy: String,
    pub solver: String,
    pub vertices: Option<usize>,
    pub faces: Option<usize>,
    pub iterations: Option<usize>,
    pub converged: bool,
    pub stop_reason: String,
    pub init_energy: Option<f64>,
    pub final_energy: Option<f64>,
    pub grad_norm: Option<f64>,
    pub time_s: Option<f64>,
    pub ms_per_vertex: Option<f64>,
    pub iter_ms_median: Option<f64>,
    pub project_ms_median: Option<f64>,
    pub solve_ms_median: Option<f64>,
    pub flips: Option<usize>,
    pub status: String,
    pub error: String,
    #[serde(default)]
    pub area_ratio_sd: Option<f64>,
    #[serde(default)]
    pub area_ratio_mad: Option<f64>,
    #[serde(default)]
    pub authalic_energy: Option<f64>,
    #[serde(default)]
    pub folded: Option<usize>,
    /// Wall time of the system's symbolic analysis (ordering + symbolic Cholesky), which
    /// `time_s` leaves out: the runs on a mesh share it.
    #[serde(default)]
    pub analysis_s: Option<f64>,
    /// The run took the analysis computed by another run on the same mesh.
    #[serde(default)]
    pub analysis_shared: Option<bool>,
}

/// The file stem of a run: `<dataset>__<energy>__<solver>`.
pub fn run_stem(dataset: &str, energy: &str, solver: &str) -> String {
    format!("{dataset}__{energy}__{solver}")
}

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create folder", dir.display()))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp{}", std::process::id()));
    // Errors name `path`, the file the caller asked for; a failed write leaves no temporary.
    let written = std::fs::write(&tmp, bytes)
        .with_context(|| format!("{}: cannot write (temporary file {})", path.display(), tmp.display()))
        .and_then(|()| {
            std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot rename into place", path.display()))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The bytes of a CSV file mapbench wrote, refused when its last row has no line end: every
/// row is written with one, so the file was cut mid-row (and its last cell may still parse,
/// as a shorter number).
pub fn read_csv_bytes(path: &Path) -> Result<Vec<u8>> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    if bytes.last().is_some_and(|&b| b != b'\n') {
        let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
        anyhow::bail!("{}: line {line}: the row has no line end: the file was cut", path.display());
    }
    Ok(bytes)
}

/// The per-iteration CSV of one run; `best` is the best final energy of the run's
/// (dataset, energy) group over all solvers. A solver's extra columns
/// ([`IterationRecord::extra`], named by the first row) follow the design.md ones.
pub fn iteration_csv(rows: &[IterationRecord], best: f64) -> Result<Vec<u8>> {
    let extra_names: Vec<&str> = rows.first().map(|r| r.extra.iter().map(|e| e.0).collect()).unwrap_or_default();
    let mut header = csv::Writer::from_writer(Vec::new());
    header.write_record(ITERATION_COLUMNS.iter().copied().chain(extra_names.iter().copied()))?;
    let mut out = header.into_inner().context("flushing CSV")?;
    // Each part goes through csv's serializer so numbers are formatted the same way.
    let record = |value: &dyn erased::Record| -> Result<Vec<u8>> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        value.write(&mut w)?;
        let mut bytes = w.into_inner().context("flushing CSV")?;
        while bytes.last().is_some_and(|b| *b == b'\n' || *b == b'\r') {
            bytes.pop();
        }
        Ok(bytes)
    };
    for r in rows {
        let names: Vec<&str> = r.extra.iter().map(|e| e.0).collect();
        if names != extra_names {
            anyhow::bail!("row {} has extra columns {names:?}, the first row {extra_names:?}", r.iter);
        }
        out.extend(record(&IterationRow {
            iter: r.iter,
            energy: r.energy,
            energy_minus_best: r.energy - best,
            grad_norm: r.grad_norm,
            step: r.step,
            neg_eig: r.neg_eig,
            indefinite_elems: r.indefinite_elems,
            flips: r.flips,
            t_assemble_s: r.t_assemble_s,
            t_project_s: r.t_project_s,
            t_solve_s: r.t_solve_s,
            t_linesearch_s: r.t_linesearch_s,
            t_iter_s: r.t_iter_s,
            t_cum_s: r.t_cum_s,
            ls_evals: r.ls_evals,
        })?);
        if !r.extra.is_empty() {
            out.push(b',');
            out.extend(record(&r.extra.iter().map(|e| e.1).collect::<Vec<f64>>())?);
        }
        out.push(b'\n');
    }
    Ok(out)
}

/// Serializing either a row struct or a list of numbers through one csv writer.
mod erased {
    pub trait Record {
        fn write(&self, w: &mut csv::Writer<Vec<u8>>) -> csv::Result<()>;
    }
    impl<T: serde::Serialize> Record for T {
        fn write(&self, w: &mut csv::Writer<Vec<u8>>) -> csv::Result<()> {
            w.serialize(self)
        }
    }
}

/// `summary.csv`, appended a row at a time as runs finish (flushed each time).
pub struct SummaryWriter {
    path: PathBuf,
    file: File,
}

impl SummaryWriter {
    /// Start a new summary (header only).
    pub fn create(path: &Path) -> Result<SummaryWriter> {
        let mut header = csv::Writer::from_writer(Vec::new());
        header.write_record(SUMMARY_COLUMNS)?;
        write_atomic(path, &header.into_inner()?)?;
        let file =
            OpenOptions::new().append(true).open(path).with_context(|| format!("{}: cannot open", path.display()))?;
        Ok(SummaryWriter { path: path.to_path_buf(), file })
    }

    pub fn append(&mut self, row: &SummaryRow) -> Result<()> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        w.serialize(row)?;
        let bytes = w.into_inner()?;
        self.file.write_all(&bytes).with_context(|| format!("{}: cannot append", self.path.display()))?;
        self.file.flush()?;
        Ok(())
    }
}

/// Write a whole `summary.csv` atomically (the batch's final, canonically ordered one).
pub fn write_summary(path: &Path, rows: &[SummaryRow]) -> Result<()> {
    // The header is written by hand so that an empty summary has one too.
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
    w.write_record(SUMMARY_COLUMNS)?;
    for r in rows {
        w.serialize(r)?;
    }
    write_atomic(path, &w.into_inner().context("flushing CSV")?)
}

/// A CSV reader error as `FILE: line N: what`; `header` names the column of a bad cell and
/// `record` (the row being deserialized) quotes it.
pub fn csv_error(
    path: &Path,
    header: Option<&csv::StringRecord>,
    record: Option<&csv::StringRecord>,
    e: &csv::Error,
) -> anyhow::Error {
    use csv::ErrorKind;
    let column = |i: usize| match header.and_then(|h| h.get(i)) {
        Some(name) => format!("column {} `{name}`", i + 1),
        None => format!("column {}", i + 1),
    };
    let (pos, what) = match e.kind() {
        ErrorKind::Utf8 { pos, err } => (pos, format!("{}: not UTF-8 text", column(err.field()))),
        ErrorKind::UnequalLengths { pos, expected_len, len } => {
            (pos, format!("{len} cells where the header has {expected_len}: the row is cut or corrupt"))
        }
        ErrorKind::Deserialize { pos, err } => (
            pos,
            match err.field().map(|i| i as usize) {
                Some(i) => match record.and_then(|r| r.get(i)) {
                    Some(cell) => format!("{}: `{cell}`: {}", column(i), err.kind()),
                    None => format!("{}: {}", column(i), err.kind()),
                },
                None => err.kind().to_string(),
            },
        ),
        _ => (&None, e.to_string()),
    };
    match pos {
        Some(p) => anyhow::anyhow!("{}: line {}: {what}", path.display(), p.line()),
        None => anyhow::anyhow!("{}: {what}", path.display()),
    }
}

/// Read a run folder's `summary.csv`; errors name the file, the line and the column.
pub fn read_summary(run_dir: &Path) -> Result<Vec<SummaryRow>> {
    let path = run_dir.join("summary.csv");
    let bytes = read_csv_bytes(&path)?;
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header = r.headers().map_err(|e| csv_error(&path, None, None, &e))?.clone();
    // The design columns up to `error` are in every summary mapbench wrote (an empty or
    // foreign file would otherwise read as a batch of no runs).
    let required = &SUMMARY_COLUMNS[..=SUMMARY_COLUMNS.iter().position(|c| *c == "error").unwrap_or(0)];
    if let Some(missing) = required.iter().find(|c| !header.iter().any(|h| h == **c)) {
        anyhow::bail!("{}: line 1: no column `{missing}`: not a mapbench summary", path.display());
    }
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| csv_error(&path, Some(&header), None, &e))?;
        let row: SummaryRow =
            rec.deserialize(Some(&header)).map_err(|e| csv_error(&path, Some(&header), Some(&rec), &e))?;
        // `report` and `merge` derive file names from these fields: a folder written by
        // another tool or edited by hand must not make them write outside the run folder.
        for (kind, name) in [("dataset", &row.dataset), ("energy", &row.energy), ("solver", &row.solver)] {
            crate::plan::names::check_name(kind, name)
                .with_context(|| format!("{}: line {}", path.display(), rec.position().map_or(0, |p| p.line())))?;
        }
        rows.push(row);
    }
    Ok(rows)
}

/// Median of a non-empty slice (`None` when empty).
pub fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 { values[n / 2] } else { 0.5 * (values[n / 2 - 1] + values[n / 2]) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_exactly_the_design_columns() {
        let rows = vec![IterationRecord { iter: 0, energy: 3.0, ..Default::default() }];
        let text = String::from_utf8(iteration_csv(&rows, 2.5).unwrap()).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), ITERATION_COLUMNS.join(","));
        assert!(lines.next().unwrap().starts_with("0,3.0,0.5,"));
        let with_extra = vec![
            IterationRecord { iter: 0, energy: 3.0, extra: vec![("a", 1.5), ("b", f64::NAN)], ..Default::default() },
            IterationRecord { iter: 1, energy: 2.75, extra: vec![("a", 0.0), ("b", 1e-20)], ..Default::default() },
        ];
        let text = String::from_utf8(iteration_csv(&with_extra, 2.5).unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], format!("{},a,b", ITERATION_COLUMNS.join(",")));
        assert!(lines[1].starts_with("0,3.0,0.5,") && lines[1].ends_with(",0,1.5,NaN"), "{}", lines[1]);
        assert!(lines[2].ends_with(",0.0,1e-20"), "{}", lines[2]);
        let mut bad = with_extra.clone();
        bad[1].extra.pop();
        assert!(iteration_csv(&bad, 0.0).is_err());
        let empty = String::from_utf8(iteration_csv(&[], 0.0).unwrap()).unwrap();
        assert_eq!(empty.trim(), ITERATION_COLUMNS.join(","));
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(SummaryRow::default()).unwrap();
        let s = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(s.lines().next().unwrap(), SUMMARY_COLUMNS.join(","));
    }

    #[test]
    fn medians() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), Some(2.5));
    }
}
