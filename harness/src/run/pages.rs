//! The pages a batch ends with, which the report layer renders: `run` and `merge` decide
//! when (the order matters to a stopped batch and to a merge that fails halfway), the
//! caller hands in how ([`Pages`], the CLI passes `report::Renderer`).

use crate::history::{trend_dir, Decision, HistoryDb, HistoryError, HistoryOutcome};
use crate::run_folder::SummaryRow;
use anyhow::Result;
use std::path::Path;

/// Renders the pages of a finished batch.
pub trait Pages: Sync {
    /// The run folder `dir`'s report (`index.html`, tables, plots) from its summary `rows`.
    fn report(&self, dir: &Path, rows: &[SummaryRow]) -> Result<()>;
    /// The trend page of `config` from `history` into `dir`.
    fn trend(&self, history: &HistoryDb, config: &str, dir: &Path) -> Result<(), HistoryError>;
}

/// Carry out `decision` for the finished folder `folder` and the database `db`
/// ([`HistoryOutcome::conclude`]), render the config's trend page after an append, and record the
/// outcome in `folder`'s `meta.json`, where the report reads it.
pub(super) fn conclude_history(
    pages: &dyn Pages,
    db: Option<&Path>,
    folder: &Path,
    recorded_as: &Path,
    decision: Decision,
) -> Result<HistoryOutcome, HistoryError> {
    let (mut outcome, appended) = HistoryOutcome::conclude(db, folder, recorded_as, decision);
    if let (Some(db), Some(a)) = (db, appended) {
        let dir = trend_dir(db, &a.config);
        outcome.set_trend(pages.trend(&a.history, &a.config, &dir).map(|()| dir.join("index.html")));
    }
    outcome.write_into(folder)?;
    Ok(outcome)
}

/// Take an appended batch out of the history again (its folder could not be put in place),
/// and render its config's trend page without it. Best effort: says what failed.
pub(super) fn withdraw(pages: &dyn Pages, outcome: &HistoryOutcome) -> Result<(), HistoryError> {
    match (outcome.withdraw()?, outcome) {
        (Some(history), HistoryOutcome::Appended { db, config, .. }) => {
            pages.trend(&history, config, &trend_dir(db, config))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paths::absolute;
    use crate::run_folder::{summary_csv, write_summary};
    use std::sync::Mutex;

    /// Notes each trend page asked for, with the batches its config then has; fails when told.
    #[derive(Default)]
    struct Fake {
        trends: Mutex<Vec<(String, usize)>>,
        fail: bool,
    }

    impl Pages for Fake {
        fn report(&self, _: &Path, _: &[SummaryRow]) -> Result<()> {
            Ok(())
        }

        fn trend(&self, history: &HistoryDb, config: &str, dir: &Path) -> Result<(), HistoryError> {
            if self.fail {
                return Err(HistoryError::Meta { path: dir.to_path_buf(), what: "in the way".into() });
            }
            let batches = history.batches(Some(config), None)?.len();
            self.trends.lock().unwrap().push((config.to_string(), batches));
            Ok(())
        }
    }

    fn folder(dir: &Path) -> std::path::PathBuf {
        let f = dir.join("f");
        std::fs::create_dir_all(&f).unwrap();
        std::fs::write(f.join("meta.json"), r#"{"config": {"name": "c"}}"#).unwrap();
        write_summary(&summary_csv(&f), &[]).unwrap();
        f
    }

    /// The trend page follows the append and precedes meta.json, which names it; a withdrawal
    /// renders it again without the batch.
    #[test]
    fn an_append_renders_the_trend_page_and_a_withdrawal_renders_it_again() {
        let dir = tempfile::tempdir().unwrap();
        let (db, f) = (dir.path().join("h.sqlite"), folder(dir.path()));
        let pages = Fake::default();
        let outcome = conclude_history(&pages, Some(&db), &f, &f, Decision::Append).unwrap();
        let HistoryOutcome::Appended { trend, trend_error: None, .. } = &outcome else { panic!("{outcome:?}") };
        assert_eq!(trend.as_ref(), Some(&absolute(&trend_dir(&db, "c").join("index.html"))));
        assert_eq!(HistoryOutcome::of_folder(&f), Some(outcome.clone()));
        withdraw(&pages, &outcome).unwrap();
        assert_eq!(*pages.trends.lock().unwrap(), [("c".to_string(), 1), ("c".to_string(), 0)]);
    }

    /// A trend page that fails is the outcome's `trend_error`: the batch is in all the same.
    #[test]
    fn a_failed_trend_page_is_recorded_not_raised() {
        let dir = tempfile::tempdir().unwrap();
        let (db, f) = (dir.path().join("h.sqlite"), folder(dir.path()));
        let pages = Fake { fail: true, ..Fake::default() };
        let outcome = conclude_history(&pages, Some(&db), &f, &f, Decision::Append).unwrap();
        let HistoryOutcome::Appended { batch_id: 1, trend: None, trend_error: Some(e), .. } = &outcome else {
            panic!("{outcome:?}")
        };
        assert!(e.ends_with("in the way"), "{e}");
        assert_eq!(HistoryOutcome::of_folder(&f), Some(outcome.clone()));
    }
}
