//! The per-iteration CSV of a run (docs/src/reference/columns.md): the common columns, then the
//! extra columns of the solver that wrote it; one writer and one reader, by header name.

use super::error::{csv_error, read_csv_bytes, FolderError};
use super::summary::SummaryRow;
use crate::names::run_stem;
use anyhow::{Context, Result};
use serde::Serialize;
use solvers::solver::IterationRecord;
use std::path::Path;

/// Per-iteration CSV columns, in the book's order; `shift` (empty when the row has no Newton
/// system), `ls_evals`, `gap` (the row's relative gap to the reference minimum the run is
/// judged by; empty without one) and `t_record_s` (the row's record-only work, outside
/// `t_iter_s`, `t_cum_s` and the run's `time_s`) follow as extras.
pub const ITERATION_COLUMNS: [&str; 18] = [
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
    "shift",
    "ls_evals",
    "gap",
    "t_record_s",
];

/// The columns a file written before they existed may lack (read as empty; `t_record_s` as 0,
/// nothing was timed apart).
const OPTIONAL_COLUMNS: [&str; 3] = ["shift", "gap", "t_record_s"];

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
    shift: Option<f64>,
    ls_evals: usize,
    gap: Option<f64>,
    t_record_s: f64,
}

/// The per-iteration CSV of one run; `best` is the best final energy of the run's
/// (dataset, energy) group over all solvers, `e_star` the reference minimum it is judged by
/// and `gap_scale` the span of its gaps (the `gap` column; `E0 - E*` when not given). A
/// solver's extra columns ([`IterationRecord::extra`], named by the first row) follow the
/// common ones.
pub fn iteration_csv(
    rows: &[IterationRecord],
    best: f64,
    e_star: Option<f64>,
    gap_scale: Option<f64>,
) -> Result<Vec<u8>> {
    let span = e_star.zip(rows.first()).map(|(s, r0)| (s, gap_scale.unwrap_or(r0.energy - s)));
    let extra_names: Vec<&str> = rows.first().map(|r| r.extra.iter().map(|e| e.0).collect()).unwrap_or_default();
    let mut header = csv::Writer::from_writer(Vec::new());
    header.write_record(ITERATION_COLUMNS.iter().copied().chain(extra_names.iter().copied()))?;
    let mut out = header.into_inner().context("flushing CSV")?;
    // Each part goes through csv's serializer so numbers are formatted the same way.
    let record = |value: &dyn erased::CsvRecord| -> Result<Vec<u8>> {
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
            shift: r.shift,
            ls_evals: r.ls_evals,
            // An external solver's row without a verified map has no energy of ours (NaN).
            gap: span.filter(|_| !r.energy.is_nan()).map(|(s, span)| crate::convergence::gap_on(r.energy, s, span)),
            t_record_s: r.t_record_s,
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
    pub trait CsvRecord {
        fn write(&self, w: &mut csv::Writer<Vec<u8>>) -> csv::Result<()>;
    }
    impl<T: serde::Serialize> CsvRecord for T {
        fn write(&self, w: &mut csv::Writer<Vec<u8>>) -> csv::Result<()> {
            w.serialize(self)
        }
    }
}

/// A per-iteration CSV read back: its rows and, per row, its `energy_minus_best` as written
/// (the plots draw that column; recomputing it would not round the same way).
#[derive(Debug)]
pub struct IterationFile {
    pub rows: Vec<IterationRecord>,
    pub energy_minus_best: Vec<f64>,
}

/// The one reader of per-iteration CSVs (resume, report, plots), columns by header name.
/// Every error names the file and the line, and the column of a bad cell.
/// `extra_columns` are the solver's extra columns (`None`: any plain name, an external
/// solver's).
pub fn read_iterations(path: &Path, extra_columns: Option<&[&'static str]>) -> Result<IterationFile, FolderError> {
    let bytes = read_csv_bytes(path)?;
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header = r.headers().map_err(|e| csv_error(path, None, None, &e))?.clone();
    let at_line = |line: u64, what: String| FolderError::Line { path: path.to_path_buf(), line, what };
    // `None`: an optional column the file does not have.
    let col = |name: &str| match header.iter().position(|h| h == name) {
        Some(j) => Ok(Some(j)),
        None if OPTIONAL_COLUMNS.contains(&name) => Ok(None),
        None => Err(at_line(1, format!("no column `{name}`: not a mapbench iteration CSV"))),
    };
    let cols: Vec<Option<usize>> = ITERATION_COLUMNS.iter().map(|n| col(n)).collect::<Result<_, _>>()?;
    // The columns after the design ones are a solver's extras; `fill_energy_minus_best` rewrites the file
    // from the records, so a column they cannot hold is refused rather than dropped.
    let mut extra_cols: Vec<(&'static str, usize)> = Vec::new();
    for (j, name) in header.iter().enumerate().filter(|(_, n)| !ITERATION_COLUMNS.contains(n)) {
        let known = match extra_columns {
            Some(declared) => declared.iter().copied().find(|k| *k == name),
            None => crate::column_names::is_column_name(name).then(|| crate::column_names::intern(name)),
        };
        let known = known.ok_or_else(|| at_line(1, format!("unknown column `{name}`")))?;
        extra_cols.push((known, j));
    }
    let mut out = IterationFile { rows: Vec::new(), energy_minus_best: Vec::new() };
    for rec in r.records() {
        let rec = rec.map_err(|e| csv_error(path, Some(&header), None, &e))?;
        let line = rec.position().map_or(0, |p| p.line());
        // A missing optional column reads as empty cells (only `opt` accepts those).
        let cell = |k: usize| match cols[k] {
            Some(j) => (j, rec.get(j).unwrap_or("")),
            None => (usize::MAX, ""),
        };
        let bad = |j: usize, text: &str, what: &str| {
            at_line(line, format!("column {} `{}`: `{text}` is not {what}", j + 1, &header[j]))
        };
        let f = |k: usize| -> Result<f64, FolderError> {
            let (j, text) = cell(k);
            text.parse().map_err(|_| bad(j, text, "a number"))
        };
        let u = |k: usize| -> Result<usize, FolderError> {
            let (j, text) = cell(k);
            text.parse().map_err(|_| bad(j, text, "a count"))
        };
        let opt = |k: usize| -> Result<Option<f64>, FolderError> {
            match cell(k) {
                (_, "") => Ok(None),
                (j, text) => text.parse().map(Some).map_err(|_| bad(j, text, "a number or empty")),
            }
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
            shift: opt(14)?,
            ls_evals: u(15)?,
            t_record_s: opt(17)?.unwrap_or(0.0),
            extra,
        });
    }
    Ok(out)
}

/// The extra columns the catalogue declares for `solver`; `None` (any) for a solver outside it,
/// an external one.
pub fn extra_columns(solver: &str) -> Option<&'static [&'static str]> {
    solvers::tasks::catalogue::find(solver).map(|e| e.extra_columns)
}

/// The per-iteration CSV of the run `s` in `run_dir`, refused unless it has the row of every
/// iteration the summary counts (a file cut at a row boundary still parses).
pub fn read_run(run_dir: &Path, s: &SummaryRow) -> Result<IterationFile, FolderError> {
    let path = super::layout::iterations_csv(run_dir, &run_stem(&s.dataset, &s.energy, &s.solver));
    let file = read_iterations(&path, extra_columns(&s.solver))?;
    if let Some(n) = s.iterations {
        // Iteration 0 (the initial state) has a row too.
        if file.rows.len() != n + 1 {
            return Err(FolderError::RowCount { path, rows: file.rows.len(), iterations: n });
        }
    }
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_exactly_the_design_columns() {
        let rows = vec![IterationRecord { iter: 0, energy: 3.0, ..Default::default() }];
        let text = String::from_utf8(iteration_csv(&rows, 2.5, None, None).unwrap()).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), ITERATION_COLUMNS.join(","));
        assert!(lines.next().unwrap().starts_with("0,3.0,0.5,"));
        let with_extra = vec![
            IterationRecord { iter: 0, energy: 3.0, extra: vec![("a", 1.5), ("b", f64::NAN)], ..Default::default() },
            IterationRecord { iter: 1, energy: 2.75, extra: vec![("a", 0.0), ("b", 1e-20)], ..Default::default() },
        ];
        let text = String::from_utf8(iteration_csv(&with_extra, 2.5, None, None).unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], format!("{},a,b", ITERATION_COLUMNS.join(",")));
        assert!(lines[1].starts_with("0,3.0,0.5,") && lines[1].ends_with(",0,,0.0,1.5,NaN"), "{}", lines[1]);
        assert!(lines[2].ends_with(",0,,0.0,0.0,1e-20"), "{}", lines[2]);
        // against E* = 2.5 the start has gap 1 and the next row (E - E*) / (E0 - E*) = 0.5
        let judged = String::from_utf8(iteration_csv(&with_extra, 2.5, Some(2.5), None).unwrap()).unwrap();
        let lines: Vec<&str> = judged.lines().collect();
        assert!(lines[1].ends_with(",0,1.0,0.0,1.5,NaN") && lines[2].ends_with(",0,0.5,0.0,0.0,1e-20"), "{judged}");
        let mut bad = with_extra.clone();
        bad[1].extra.pop();
        assert!(iteration_csv(&bad, 0.0, None, None).is_err());
        let empty = String::from_utf8(iteration_csv(&[], 0.0, None, None).unwrap()).unwrap();
        assert_eq!(empty.trim(), ITERATION_COLUMNS.join(","));
    }

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
                shift: Some(1.0000000000000001e-7),
                extra: vec![("ascent", 1.0), ("wolfe", 1.0)],
                ..Default::default()
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        std::fs::write(&p, crate::run_folder::iteration_csv(&rows, 2.0, None, None).unwrap()).unwrap();
        let back = read_iterations(&p, Some(&["ascent", "wolfe"])).unwrap().rows;
        assert_eq!(back.len(), 2);
        assert_eq!(back[1], rows[1]);
        assert_eq!(back[0].energy, 3.0);
        assert!(back[0].extra[1].1.is_nan());
        std::fs::write(&p, "a,b\n1,2\n").unwrap();
        assert!(read_iterations(&p, Some(&[])).is_err());
    }

    /// `shift` sits right after `t_cum_s`, empty when the row has no Newton system (row 0,
    /// authalic runs); files written before it existed still read, with no shift.
    #[test]
    fn the_shift_column_is_written_after_t_cum_s_and_optional_on_read() {
        let rows = vec![
            IterationRecord { iter: 0, energy: 3.0, ..Default::default() },
            IterationRecord {
                iter: 1,
                energy: 2.5,
                t_cum_s: 0.5,
                shift: Some(1e-10),
                ls_evals: 2,
                ..Default::default()
            },
        ];
        let text = String::from_utf8(iteration_csv(&rows, 2.5, None, None).unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].ends_with(",t_iter_s,t_cum_s,shift,ls_evals,gap,t_record_s"), "{}", lines[0]);
        assert!(lines[1].ends_with(",0.0,0.0,,0,,0.0"), "{}", lines[1]);
        assert!(lines[2].ends_with(",0.0,0.5,1e-10,2,,0.0"), "{}", lines[2]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        std::fs::write(&p, &text).unwrap();
        assert_eq!(read_iterations(&p, Some(&[])).unwrap().rows, rows);
        // an older file: no shift column (nor t_record_s, which came later)
        let old: String = text
            .lines()
            .map(|l| l.trim_end_matches(",t_record_s").trim_end_matches(",0.0"))
            .map(|l| l.replace(",shift,", ",").replace(",,0", ",0").replace(",1e-10,", ",") + "\n")
            .collect();
        assert!(
            !old.contains("shift") && old.lines().all(|l| l.split(',').count() == ITERATION_COLUMNS.len() - 2),
            "{old}"
        );
        std::fs::write(&p, &old).unwrap();
        let back = read_iterations(&p, Some(&[])).unwrap().rows;
        assert_eq!(back.iter().map(|r| r.shift).collect::<Vec<_>>(), [None, None]);
        assert_eq!((back[1].t_cum_s, back[1].ls_evals), (0.5, 2));
        // a cell that is neither a number nor empty names its column
        std::fs::write(&p, text.replace(",1e-10,", ",big,")).unwrap();
        let e = format!("{:#}", read_iterations(&p, Some(&[])).unwrap_err());
        assert!(e.contains("line 3: column 15 `shift`: `big` is not a number or empty"), "{e}");
    }

    /// `t_record_s` round-trips as the last design column; a file written before it existed
    /// reads it as 0 (nothing was timed apart).
    #[test]
    fn the_record_time_round_trips_and_is_0_in_older_files() {
        let rows = vec![
            IterationRecord { iter: 0, energy: 3.0, ..Default::default() },
            IterationRecord {
                iter: 1,
                energy: 2.5,
                t_iter_s: 0.5,
                t_cum_s: 0.5,
                t_record_s: 0.25,
                ..Default::default()
            },
        ];
        let text = String::from_utf8(iteration_csv(&rows, 2.5, None, None).unwrap()).unwrap();
        assert!(text.lines().nth(2).unwrap().ends_with(",0.25"), "{text}");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        std::fs::write(&p, &text).unwrap();
        assert_eq!(read_iterations(&p, Some(&[])).unwrap().rows, rows);
        let old: String =
            text.lines().map(|l| l.rsplit_once(',').map_or(l, |(head, _)| head).to_string() + "\n").collect();
        assert!(!old.contains("t_record_s"), "{old}");
        std::fs::write(&p, &old).unwrap();
        let back = read_iterations(&p, Some(&[])).unwrap().rows;
        assert_eq!(back.iter().map(|r| r.t_record_s).collect::<Vec<_>>(), [0.0, 0.0]);
        assert_eq!(back[1].t_cum_s, 0.5);
    }

    #[test]
    fn corrupt_iteration_csvs_are_refused_by_file_line_and_column() {
        let rows: Vec<IterationRecord> =
            (0..3).map(|i| IterationRecord { iter: i, energy: 3.0 - i as f64, ..Default::default() }).collect();
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("runs")).unwrap();
        let p = dir.path().join("runs/m__sd__cm.csv");
        let good = String::from_utf8(crate::run_folder::iteration_csv(&rows, 1.0, None, None).unwrap()).unwrap();
        let err = |text: &[u8]| {
            std::fs::write(&p, text).unwrap();
            let e = format!("{:#}", read_iterations(&p, Some(&[])).unwrap_err());
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
        // an external solver's columns are any plain names; others are refused
        let with = |name: &str| {
            let mut text = String::new();
            for (i, l) in good.lines().enumerate() {
                text += &format!("{l},{}\n", if i == 0 { name.to_string() } else { format!("{}.5", i) });
            }
            std::fs::write(&p, text).unwrap();
            read_iterations(&p, None)
        };
        let rows_x = with("decrease").unwrap().rows;
        assert_eq!(
            rows_x.iter().map(|r| r.extra.clone()).collect::<Vec<_>>(),
            [[("decrease", 1.5)], [("decrease", 2.5)], [("decrease", 3.5)]]
        );
        assert!(format!("{:#}", with("a b").unwrap_err()).contains("line 1: unknown column `a b`"));
        // columns are found by name, and energy_minus_best is kept as written
        std::fs::write(&p, &good).unwrap();
        let file = read_iterations(&p, Some(&[])).unwrap();
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
}
