//! The history database: its schema, the migrations from older versions, appending one batch
//! (one transaction) and the queries of the trend page.
//!
//! The schema version is SQLite's `PRAGMA user_version`. Opening a database of an older
//! version runs the missing [`MIGRATIONS`] in one transaction; a newer one is refused
//! ([`HistoryError::Newer`]), since this build would not know what its columns mean.

use super::claim_rows::ClaimRow;
use super::error::HistoryError;
use super::run_row::RunRow;
use crate::claims::{ClaimOutcome, Rule};
use crate::plan::Task;
use crate::run_folder::Status;
use crate::run_folder::{parse_stop, stop_text};
use rusqlite::{params, Connection, OpenFlags, OptionalExtension, Transaction};
use std::path::{Path, PathBuf};

/// The schema this build writes. docs/src/reference/history-schema.md documents it.
pub const SCHEMA_VERSION: i64 = 9;

/// `MIGRATIONS[k]` takes a database from version `k` to `k + 1` (version 0: empty).
pub const MIGRATIONS: [&str; SCHEMA_VERSION as usize] = [
    // v1: one row per batch, one per run of a batch.
    "CREATE TABLE batches (
        id INTEGER PRIMARY KEY,
        config_name TEXT NOT NULL,
        config_hash TEXT NOT NULL,
        started_unix INTEGER,
        ended_unix INTEGER,
        git_revision TEXT,
        git_dirty INTEGER,
        host TEXT,
        cores INTEGER,
        jobs INTEGER,
        threads_per_run INTEGER,
        repeats INTEGER,
        calibration_median_s REAL,
        calibration_spread REAL,
        run_dir TEXT NOT NULL,
        recorded_unix INTEGER NOT NULL
    );
    CREATE TABLE runs (
        batch_id INTEGER NOT NULL REFERENCES batches(id) ON DELETE CASCADE,
        dataset TEXT NOT NULL,
        task TEXT NOT NULL,
        energy TEXT NOT NULL,
        solver TEXT NOT NULL,
        vertices INTEGER,
        iterations INTEGER,
        status TEXT NOT NULL,
        stop_reason TEXT NOT NULL,
        final_energy REAL,
        grad_norm REAL,
        flips INTEGER,
        time_s REAL,
        time_s_min REAL,
        time_s_max REAL,
        time_norm REAL,
        repeats INTEGER,
        shifted_iters INTEGER,
        clamped_iters INTEGER,
        PRIMARY KEY (batch_id, dataset, task, energy, solver)
    );",
    // v2: whether the batch came from `run` or `merge`, and the trend page's lookup of a
    // config's batches in time order.
    "ALTER TABLE batches ADD COLUMN source TEXT NOT NULL DEFAULT 'run';
    CREATE INDEX batches_by_config ON batches(config_name, started_unix, id);",
    // v3: each run's peak resident memory (`summary.csv`'s `peak_rss_mb`).
    "ALTER TABLE runs ADD COLUMN peak_rss_mb REAL;",
    // v4: the harness's verdict (`summary.csv`'s `start` .. `verdict`).
    "ALTER TABLE runs ADD COLUMN start TEXT;
    ALTER TABLE runs ADD COLUMN ref_energy REAL;
    ALTER TABLE runs ADD COLUMN ref_source TEXT;
    ALTER TABLE runs ADD COLUMN final_gap REAL;
    ALTER TABLE runs ADD COLUMN verdict TEXT;",
    // v5: the truncated solvers' steps at the CG cap (`summary.csv`'s `cg_capped_iters`),
    // counted like `shifted_iters` and `clamped_iters`.
    "ALTER TABLE runs ADD COLUMN cg_capped_iters INTEGER;",
    // v6: the tightest target a judged run was held to and, when it reached it, the
    // iterations and time to it (`summary.csv`'s `iters_to_*` and `time_to_*`): the trend
    // page's solved counts and means to the target; and the run's own peak memory
    // (`summary.csv`'s `peak_growth_mb`).
    "ALTER TABLE runs ADD COLUMN target_tau REAL;
    ALTER TABLE runs ADD COLUMN iters_to_target INTEGER;
    ALTER TABLE runs ADD COLUMN time_s_to_target REAL;
    ALTER TABLE runs ADD COLUMN peak_growth_mb REAL;",
    // v7: the yardstick a judged run was held to besides `ref_energy` (the common start's
    // energy, the energy's isometry value, whether E* is certified), so that two batches
    // judged against different references can be judged again against the lower one; the
    // polish that confirms another minimum; a repeat that did not reproduce the first.
    "ALTER TABLE runs ADD COLUMN start_energy REAL;
    ALTER TABLE runs ADD COLUMN ideal_energy REAL;
    ALTER TABLE runs ADD COLUMN ref_certified INTEGER;
    ALTER TABLE runs ADD COLUMN polished_energy REAL;
    ALTER TABLE runs ADD COLUMN repeats_differ TEXT;",
    // v8: the papers' claims each batch answered, by rule, with their outcomes (`claims`).
    "CREATE TABLE claims (
        batch_id INTEGER NOT NULL REFERENCES batches(id) ON DELETE CASCADE,
        claim TEXT NOT NULL,
        rule TEXT NOT NULL,
        outcome TEXT NOT NULL,
        why TEXT NOT NULL,
        PRIMARY KEY (batch_id, claim, rule)
    );",
    // v9: where each tolerance rule first held in a run (`summary.csv`'s `rule_*` columns):
    // runs go on to their target, and the papers' rule reads them at these events.
    "ALTER TABLE runs ADD COLUMN rule_grad_tol_iters INTEGER;
    ALTER TABLE runs ADD COLUMN rule_grad_tol_time_s REAL;
    ALTER TABLE runs ADD COLUMN rule_grad_tol_energy REAL;
    ALTER TABLE runs ADD COLUMN rule_energy_decrease_iters INTEGER;
    ALTER TABLE runs ADD COLUMN rule_energy_decrease_time_s REAL;
    ALTER TABLE runs ADD COLUMN rule_energy_decrease_energy REAL;",
];

/// Where a batch came from (`batches.source`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Source {
    #[default]
    Run,
    Merge,
}

impl Source {
    pub fn as_str(self) -> &'static str {
        match self {
            Source::Run => "run",
            Source::Merge => "merge",
        }
    }
}

impl std::str::FromStr for Source {
    type Err = String;
    fn from_str(s: &str) -> Result<Source, String> {
        [Source::Run, Source::Merge]
            .into_iter()
            .find(|x| x.as_str() == s)
            .ok_or_else(|| format!("unknown batch source '{s}' (known: run, merge)"))
    }
}

/// One row of `batches`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BatchRow {
    /// Assigned by the database on insert.
    pub id: i64,
    pub config_name: String,
    /// 16 hex digits of the resolved config and plan (`super::config_hash`).
    pub config_hash: String,
    pub started_unix: Option<i64>,
    pub ended_unix: Option<i64>,
    pub git_revision: Option<String>,
    pub git_dirty: Option<bool>,
    pub host: Option<String>,
    pub cores: Option<i64>,
    pub jobs: Option<i64>,
    pub threads_per_run: Option<i64>,
    pub repeats: Option<i64>,
    pub calibration_median_s: Option<f64>,
    pub calibration_spread: Option<f64>,
    pub run_dir: String,
    pub recorded_unix: i64,
    pub source: Source,
}

/// A past run's time (`HistoryDb::past_times`).
#[derive(Clone, Debug, PartialEq)]
pub struct PastTime {
    pub config_name: String,
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    pub solver: String,
    pub time_norm: f64,
    /// The calibration time of the run's batch (seconds), when it was calibrated.
    pub calibration_median_s: Option<f64>,
}

impl BatchRow {
    /// The revision's first 7 hex digits, `+` when the tree was dirty, `?` when unknown.
    pub fn short_revision(&self) -> String {
        let rev = self.git_revision.as_deref().map_or("?", |r| &r[..r.len().min(7)]);
        format!("{rev}{}", if self.git_dirty == Some(true) { "+" } else { "" })
    }
}

/// An open history database at the current schema version.
pub struct HistoryDb {
    conn: Connection,
    path: PathBuf,
}

impl HistoryDb {
    /// Open (creating it and its folder when absent) and migrate to [`SCHEMA_VERSION`].
    pub fn open_or_create(path: &Path) -> Result<HistoryDb, HistoryError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|err| HistoryError::Io {
                path: dir.to_path_buf(),
                what: "cannot create folder",
                err,
            })?;
        }
        Self::open_with(path, OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_CREATE, true)
    }

    /// Open an existing history (an error when there is none, or the file is empty: only
    /// `run` and `merge` create one) and migrate an older schema to [`SCHEMA_VERSION`].
    pub fn open_existing(path: &Path) -> Result<HistoryDb, HistoryError> {
        if !path.is_file() {
            return Err(HistoryError::Missing { path: path.to_path_buf() });
        }
        Self::open_with(path, OpenFlags::SQLITE_OPEN_READ_WRITE, false)
    }

    fn open_with(path: &Path, flags: OpenFlags, create: bool) -> Result<HistoryDb, HistoryError> {
        let sql = sql_error(path);
        let conn = Connection::open_with_flags(path, flags).map_err(&sql)?;
        // Another process appending at the same moment waits instead of failing.
        conn.busy_timeout(std::time::Duration::from_secs(10)).map_err(&sql)?;
        conn.pragma_update(None, "foreign_keys", true).map_err(&sql)?;
        let mut db = HistoryDb { conn, path: path.to_path_buf() };
        db.migrate(create)?;
        Ok(db)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The database's `user_version`.
    pub fn version(&self) -> Result<i64, HistoryError> {
        user_version(&self.conn).map_err(sql_error(&self.path))
    }

    /// Bring the schema to [`SCHEMA_VERSION`] in one transaction: a migration that fails
    /// leaves the database at its old version. An empty file (version 0, no tables) becomes
    /// a history only when `create`.
    fn migrate(&mut self, create: bool) -> Result<(), HistoryError> {
        let path = self.path.clone();
        let sql = sql_error(&path);
        // `user_version` is any 32-bit integer: a negative one was set by someone else.
        let found = user_version(&self.conn).map_err(&sql)?;
        let from = usize::try_from(found).map_err(|_| HistoryError::BadVersion { path: path.clone(), found })?;
        if found > SCHEMA_VERSION {
            return Err(HistoryError::Newer { path: path.clone(), found, supported: SCHEMA_VERSION });
        }
        if found == SCHEMA_VERSION {
            return Ok(());
        }
        let tx = self.conn.transaction().map_err(&sql)?;
        if found == 0 {
            // Version 0 is a new, empty file; a database with tables of its own and no
            // version is someone else's.
            let tables: i64 = tx
                .query_row("SELECT count(*) FROM sqlite_master WHERE type = 'table'", [], |r| r.get(0))
                .map_err(&sql)?;
            if tables > 0 {
                return Err(HistoryError::Foreign { path: path.clone() });
            }
            if !create {
                return Err(HistoryError::Empty { path: path.clone() });
            }
        }
        for step in &MIGRATIONS[from..] {
            tx.execute_batch(step).map_err(&sql)?;
        }
        tx.pragma_update(None, "user_version", SCHEMA_VERSION).map_err(&sql)?;
        tx.commit().map_err(&sql)
    }

    /// Remove batch `id` and its runs (a merge that could not put its folder in place).
    pub fn remove_batch(&self, id: i64) -> Result<(), HistoryError> {
        self.conn.execute("DELETE FROM batches WHERE id = ?1", params![id]).map(|_| ()).map_err(sql_error(&self.path))
    }

    /// Append one batch, its runs and the outcomes of the papers' claims it answered in one
    /// transaction; returns the batch's id. On any error nothing of the batch is left.
    pub fn insert_batch(
        &mut self,
        batch: &BatchRow,
        runs: &[RunRow],
        claims: &[ClaimRow],
    ) -> Result<i64, HistoryError> {
        let path = self.path.clone();
        let sql = sql_error(&path);
        let tx = self.conn.transaction().map_err(&sql)?;
        let id = insert_in(&tx, batch, runs).map_err(|e| match e {
            InsertError::Sql(e) => sql(e),
            InsertError::Run { run, source } => HistoryError::Run { path: path.clone(), run, err: source },
        })?;
        insert_claims(&tx, id, claims).map_err(&sql)?;
        tx.commit().map_err(&sql)?;
        Ok(id)
    }

    /// The batches of `config` (every config when `None`), oldest first; the last `last`
    /// of each config when given.
    pub fn batches(&self, config: Option<&str>, last: Option<usize>) -> Result<Vec<BatchRow>, HistoryError> {
        let sql = sql_error(&self.path);
        let mut stmt = self
            .conn
            .prepare(
                "SELECT id, config_name, config_hash, started_unix, ended_unix, git_revision, git_dirty, host, \
                 cores, jobs, threads_per_run, repeats, calibration_median_s, calibration_spread, run_dir, \
                 recorded_unix, source FROM batches WHERE ?1 IS NULL OR config_name = ?1 \
                 ORDER BY config_name, started_unix, id",
            )
            .map_err(&sql)?;
        let rows = stmt
            .query_map([config], |r| {
                Ok(BatchRow {
                    id: r.get(0)?,
                    config_name: r.get(1)?,
                    config_hash: r.get(2)?,
                    started_unix: r.get(3)?,
                    ended_unix: r.get(4)?,
                    git_revision: r.get(5)?,
                    git_dirty: r.get(6)?,
                    host: r.get(7)?,
                    cores: r.get(8)?,
                    jobs: r.get(9)?,
                    threads_per_run: r.get(10)?,
                    repeats: r.get(11)?,
                    calibration_median_s: r.get(12)?,
                    calibration_spread: r.get(13)?,
                    run_dir: r.get(14)?,
                    recorded_unix: r.get(15)?,
                    source: parse_text(r, 16, |t| t.parse::<Source>())?,
                })
            })
            .map_err(&sql)?
            .collect::<Result<Vec<_>, _>>()
            .map_err(&sql)?;
        let Some(n) = last else { return Ok(rows) };
        // Keep the last n of each config (rows are grouped by config, in time order).
        let mut kept = Vec::with_capacity(rows.len());
        for (i, b) in rows.iter().enumerate() {
            let later_of_same = rows[i + 1..].iter().filter(|o| o.config_name == b.config_name).count();
            if later_of_same < n {
                kept.push(b.clone());
            }
        }
        Ok(kept)
    }

    /// The runs of a batch, in the order they were inserted (the summary's order).
    pub fn runs(&self, batch_id: i64) -> Result<Vec<RunRow>, HistoryError> {
        let path = &self.path;
        let sql = sql_error(path);
        let mut stmt = self
            .conn
            .prepare(
                "SELECT batch_id, dataset, task, energy, solver, vertices, iterations, status, stop_reason, \
                 final_energy, grad_norm, flips, time_s, time_s_min, time_s_max, time_norm, repeats, \
                 shifted_iters, clamped_iters, peak_rss_mb, start, ref_energy, ref_source, final_gap, verdict, \
                 cg_capped_iters, target_tau, iters_to_target, time_s_to_target, peak_growth_mb, start_energy, \
                 ideal_energy, ref_certified, polished_energy, repeats_differ, rule_grad_tol_iters, \
                 rule_grad_tol_time_s, rule_grad_tol_energy, rule_energy_decrease_iters, \
                 rule_energy_decrease_time_s, rule_energy_decrease_energy FROM runs WHERE batch_id = ?1 \
                 ORDER BY rowid",
            )
            .map_err(&sql)?;
        let rows = stmt
            .query_map([batch_id], |r| {
                let status = parse_text(r, 7, |t| t.parse::<Status>())?;
                let stop_reason = parse_text(r, 8, parse_stop)?;
                Ok(RunRow {
                    batch_id: r.get(0)?,
                    dataset: r.get(1)?,
                    task: parse_text(r, 2, |t| t.parse::<Task>())?,
                    energy: r.get(3)?,
                    solver: r.get(4)?,
                    vertices: r.get(5)?,
                    iterations: r.get(6)?,
                    status,
                    stop_reason,
                    final_energy: r.get(9)?,
                    grad_norm: r.get(10)?,
                    flips: r.get(11)?,
                    time_s: r.get(12)?,
                    time_s_min: r.get(13)?,
                    time_s_max: r.get(14)?,
                    time_norm: r.get(15)?,
                    repeats: r.get(16)?,
                    shifted_iters: r.get(17)?,
                    clamped_iters: r.get(18)?,
                    peak_rss_mb: r.get(19)?,
                    start: r.get(20)?,
                    ref_energy: r.get(21)?,
                    ref_source: r.get(22)?,
                    final_gap: r.get(23)?,
                    verdict: r.get(24)?,
                    cg_capped_iters: r.get(25)?,
                    target_tau: r.get(26)?,
                    iters_to_target: r.get(27)?,
                    time_s_to_target: r.get(28)?,
                    peak_growth_mb: r.get(29)?,
                    start_energy: r.get(30)?,
                    ideal_energy: r.get(31)?,
                    ref_certified: r.get(32)?,
                    polished_energy: r.get(33)?,
                    repeats_differ: r.get(34)?,
                    rule_grad_tol_iters: r.get(35)?,
                    rule_grad_tol_time_s: r.get(36)?,
                    rule_grad_tol_energy: r.get(37)?,
                    rule_energy_decrease_iters: r.get(38)?,
                    rule_energy_decrease_time_s: r.get(39)?,
                    rule_energy_decrease_energy: r.get(40)?,
                })
            })
            .map_err(&sql)?
            .collect::<Result<Vec<_>, _>>()
            .map_err(&sql)?;
        Ok(rows)
    }

    /// Every run's `time_norm` with its batch's config and calibration, oldest batch first:
    /// what `submit` predicts a run's time from.
    pub fn past_times(&self) -> Result<Vec<PastTime>, HistoryError> {
        let sql = sql_error(&self.path);
        let mut stmt = self
            .conn
            .prepare(
                "SELECT b.config_name, r.dataset, r.task, r.energy, r.solver, r.time_norm, b.calibration_median_s \
                 FROM runs r JOIN batches b ON b.id = r.batch_id WHERE r.time_norm IS NOT NULL \
                 ORDER BY b.started_unix, b.id, r.rowid",
            )
            .map_err(&sql)?;
        let rows = stmt
            .query_map([], |r| {
                Ok(PastTime {
                    config_name: r.get(0)?,
                    dataset: r.get(1)?,
                    task: parse_text(r, 2, |t| t.parse::<Task>())?,
                    energy: r.get(3)?,
                    solver: r.get(4)?,
                    time_norm: r.get(5)?,
                    calibration_median_s: r.get(6)?,
                })
            })
            .map_err(&sql)?
            .collect::<Result<Vec<_>, _>>()
            .map_err(&sql)?;
        Ok(rows)
    }

    /// The number of batches in the database.
    pub fn batch_count(&self) -> Result<i64, HistoryError> {
        self.conn.query_row("SELECT count(*) FROM batches", [], |r| r.get(0)).map_err(sql_error(&self.path))
    }

    /// The id of the batch recorded from `run_dir` most recently, if any.
    /// The papers' claims batch `batch_id` answered (none for a batch recorded before schema 8).
    pub fn claims(&self, batch_id: i64) -> Result<Vec<ClaimRow>, HistoryError> {
        let sql = sql_error(&self.path);
        let mut stmt = self
            .conn
            .prepare("SELECT claim, rule, outcome, why FROM claims WHERE batch_id = ?1 ORDER BY rowid")
            .map_err(&sql)?;
        let rows = stmt
            .query_map([batch_id], |r| {
                Ok(ClaimRow {
                    claim: r.get(0)?,
                    rule: parse_text(r, 1, |t| Rule::from_key(t).ok_or(format!("unknown rule '{t}'")))?,
                    outcome: parse_text(r, 2, |t| ClaimOutcome::from_key(t).ok_or(format!("unknown outcome '{t}'")))?,
                    why: r.get(3)?,
                })
            })
            .map_err(&sql)?;
        rows.collect::<Result<Vec<_>, _>>().map_err(&sql)
    }

    pub fn last_batch_of(&self, run_dir: &str) -> Result<Option<i64>, HistoryError> {
        self.conn
            .query_row("SELECT max(id) FROM batches WHERE run_dir = ?1", [run_dir], |r| r.get(0))
            .optional()
            .map(Option::flatten)
            .map_err(sql_error(&self.path))
    }
}

enum InsertError {
    Sql(rusqlite::Error),
    Run { run: String, source: rusqlite::Error },
}

impl From<rusqlite::Error> for InsertError {
    fn from(e: rusqlite::Error) -> Self {
        InsertError::Sql(e)
    }
}

fn insert_in(tx: &Transaction, b: &BatchRow, runs: &[RunRow]) -> Result<i64, InsertError> {
    let id = insert_batch(tx, b)?;
    insert_runs(tx, id, runs)?;
    Ok(id)
}

fn insert_batch(tx: &Transaction, b: &BatchRow) -> rusqlite::Result<i64> {
    tx.execute(
        "INSERT INTO batches (config_name, config_hash, started_unix, ended_unix, git_revision, git_dirty, host, \
         cores, jobs, threads_per_run, repeats, calibration_median_s, calibration_spread, run_dir, recorded_unix, \
         source) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16)",
        params![
            b.config_name,
            b.config_hash,
            b.started_unix,
            b.ended_unix,
            b.git_revision,
            b.git_dirty,
            b.host,
            b.cores,
            b.jobs,
            b.threads_per_run,
            b.repeats,
            b.calibration_median_s,
            b.calibration_spread,
            b.run_dir,
            b.recorded_unix,
            b.source.as_str(),
        ],
    )?;
    Ok(tx.last_insert_rowid())
}

fn insert_runs(tx: &Transaction, id: i64, runs: &[RunRow]) -> Result<(), InsertError> {
    let mut stmt = tx.prepare(
        "INSERT INTO runs (batch_id, dataset, task, energy, solver, vertices, iterations, status, stop_reason, \
         final_energy, grad_norm, flips, time_s, time_s_min, time_s_max, time_norm, repeats, shifted_iters, \
         clamped_iters, peak_rss_mb, start, ref_energy, ref_source, final_gap, verdict, cg_capped_iters, target_tau, \
         iters_to_target, time_s_to_target, peak_growth_mb, start_energy, ideal_energy, ref_certified, \
         polished_energy, repeats_differ, rule_grad_tol_iters, rule_grad_tol_time_s, rule_grad_tol_energy, \
         rule_energy_decrease_iters, rule_energy_decrease_time_s, rule_energy_decrease_energy) VALUES (?1, ?2, ?3, \
         ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25, \
         ?26, ?27, ?28, ?29, ?30, ?31, ?32, ?33, ?34, ?35, ?36, ?37, ?38, ?39, ?40, ?41)",
    )?;
    for r in runs {
        stmt.execute(params![
            id,
            r.dataset,
            r.task.as_str(),
            r.energy,
            r.solver,
            r.vertices,
            r.iterations,
            r.status.as_str(),
            stop_text(r.stop_reason.as_ref()),
            r.final_energy,
            r.grad_norm,
            r.flips,
            r.time_s,
            r.time_s_min,
            r.time_s_max,
            r.time_norm,
            r.repeats,
            r.shifted_iters,
            r.clamped_iters,
            r.peak_rss_mb,
            r.start,
            r.ref_energy,
            r.ref_source,
            r.final_gap,
            r.verdict,
            r.cg_capped_iters,
            r.target_tau,
            r.iters_to_target,
            r.time_s_to_target,
            r.peak_growth_mb,
            r.start_energy,
            r.ideal_energy,
            r.ref_certified,
            r.polished_energy,
            r.repeats_differ,
            r.rule_grad_tol_iters,
            r.rule_grad_tol_time_s,
            r.rule_grad_tol_energy,
            r.rule_energy_decrease_iters,
            r.rule_energy_decrease_time_s,
            r.rule_energy_decrease_energy,
        ])
        .map_err(|source| InsertError::Run {
            run: crate::run_folder::run_stem(&r.dataset, &r.energy, &r.solver),
            source,
        })?;
    }
    Ok(())
}

fn insert_claims(tx: &Transaction, batch_id: i64, rows: &[ClaimRow]) -> rusqlite::Result<()> {
    let mut stmt =
        tx.prepare("INSERT INTO claims (batch_id, claim, rule, outcome, why) VALUES (?1, ?2, ?3, ?4, ?5)")?;
    for r in rows {
        stmt.execute(params![batch_id, r.claim, r.rule.key(), r.outcome.key(), r.why])?;
    }
    Ok(())
}

/// Column `i` of `row` as text, parsed into its type (an unknown value is a conversion error
/// naming the column).
fn parse_text<T, E: std::fmt::Display>(
    row: &rusqlite::Row,
    i: usize,
    parse: impl Fn(&str) -> Result<T, E>,
) -> rusqlite::Result<T> {
    let text: String = row.get(i)?;
    parse(&text)
        .map_err(|e| rusqlite::Error::FromSqlConversionFailure(i, rusqlite::types::Type::Text, e.to_string().into()))
}

fn user_version(conn: &Connection) -> rusqlite::Result<i64> {
    conn.pragma_query_value(None, "user_version", |r| r.get(0))
}

fn sql_error(path: &Path) -> impl Fn(rusqlite::Error) -> HistoryError + '_ {
    move |err| HistoryError::Sql { path: path.to_path_buf(), err }
}
