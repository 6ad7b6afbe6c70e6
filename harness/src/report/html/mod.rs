//! `index.html` of a run folder: one self-contained page (inline CSS, no script, no network,
//! relative links only) with how the batch was timed (repeats, machine calibration and a
//! warning when the machine changed speed), the run status matrix, the tables with the corpus
//! aggregates and performance profiles, the plots, links to every file and the provenance
//! from `meta.json`. Readable on a phone: images scale down and
//! wide tables scroll sideways in their own box.

pub use crate::escape::{esc, href};
use crate::report::batch::Batch;
use crate::report::plots::Plot;
use crate::report::tables::Table;
use crate::run_folder::meta::Meta;
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

mod changes;
mod claims;
mod external;
mod figures;
mod files;
mod provenance;
mod rollup;
mod status;
#[cfg(test)]
mod tests;
mod timing;

pub(crate) use crate::utc::utc;
pub(crate) use changes::changes_body;
use changes::changes_section;
use external::{external_section, probes};
use figures::{plots_section, tables_section};
use files::files_section;
use provenance::provenance_section;
use status::status_matrix;
use timing::timing_section;

pub(crate) const STYLE: &str = "\
body{font-family:system-ui,sans-serif;margin:0 auto;padding:0 12px 40px;max-width:1400px;line-height:1.4;color:#222}\
h1{font-size:1.5em;margin:.6em 0 .2em}h2{border-bottom:1px solid #ccc;margin-top:1.6em}h3{margin:1.2em 0 .4em}\
nav a{margin-right:1em}\
.scroll{overflow-x:auto;-webkit-overflow-scrolling:touch;margin:.4em 0}\
table{border-collapse:collapse;font-size:.9em}td,th{border:1px solid #bbb;padding:3px 7px;text-align:right;vertical-align:top}td{white-space:nowrap}\
th{background:#eee}td.k,th.k{text-align:left;white-space:nowrap}\
table.claims td{white-space:normal;max-width:34em}table.claims span{padding:0 3px}\
table.status{font-size:.75em}table.status td,table.status th{text-align:center;white-space:nowrap;padding:1px 3px}table.status th{white-space:normal;vertical-align:bottom}table.status td.k{text-align:left;background:#fff}\
.ds{position:sticky;left:0;z-index:1}table.status th.ds{background:#eee}\
.scroll.status{max-height:85vh;overflow:auto}table.status th{position:sticky;top:0;z-index:2}table.status th.ds{z-index:3}\
td.fast{outline:3px solid #1a6b2e;outline-offset:-3px}\
.ok{background:#d8f0d8}.nc{background:#fff0c2}.budget{background:#dde8f6}.failed{background:#f6d0d3}.skipped{background:#e4e4e4;color:#666}\
ol.notes,ul.problems{font-size:.85em;word-break:break-word}ul.problems li{margin:2px 0}.verdict{font-size:1.1em;margin:.6em 0}\
td.none{background:#f4f4f4;color:#999}td a{color:inherit;text-decoration:none}td small{color:#555}\
img{max-width:100%;height:auto}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(100%,400px),1fr));gap:14px}\
.maps{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(45%,200px),1fr));gap:10px}\
figure{margin:0}figcaption{font-size:.85em;color:#444}\
dl{display:grid;grid-template-columns:max-content 1fr;gap:2px 14px}dt{font-weight:600}dd{margin:0;word-break:break-all}\
ul.files{columns:2 22em;font-size:.9em}code,pre{font-size:.85em}pre{overflow-x:auto;background:#f6f6f6;padding:6px}\
.caption{color:#444;font-size:.9em}\
.warn{background:#fde2c8;border:1px solid #d9822b;padding:6px 10px}";

/// Write `run_dir/index.html` from the summary rows, the tables (file stem, table), the
/// plots `render_all` wrote and the batch's calibration; the rest (meta.json, file lists) is
/// read from `run_dir`.
pub fn write_index(
    run_dir: &Path,
    summaries: &[SummaryRow],
    tables: &[(String, Table)],
    plots: &[Plot],
    batch: &Batch,
) -> Result<()> {
    let meta = read_meta(run_dir)?;
    let name = meta.as_ref().and_then(Meta::config_name).unwrap_or("run");
    let task = meta
        .as_ref()
        .and_then(|m| m.config_str("task"))
        .map(str::to_string)
        .or_else(|| summaries.first().map(|s| s.task.as_str().to_string()))
        .unwrap_or_default();
    let external = probes(meta.as_ref());
    let claims_result = papers_claims(run_dir, summaries, batch);
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>mapbench: {n}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <h1>mapbench report: {n}</h1>\n<p class=\"caption\">task <b>{t}</b></p>\n\
         <nav><a href=\"#changes\">changes</a><a href=\"#status\">status</a><a href=\"#tables\">tables</a><a href=\"#plots\">plots</a>\
         {c}{x}{e}<a href=\"#files\">files</a><a href=\"#provenance\">provenance</a></nav>\n",
        n = esc(name),
        t = esc(&task),
        c = if claims_result.as_ref().is_ok_and(|c| !c.is_empty()) { "<a href=\"#claims\">claims</a>" } else { "" },
        x = if external.is_empty() { "" } else { "<a href=\"#external\">external solvers</a>" },
        e = if run_dir.join(crate::report::plots::explorer::EXPLORER).exists() {
            "<a href=\"explorer.html\">explorer</a>"
        } else {
            ""
        },
    );
    let (claims, claims_error) = match claims_result {
        Ok(c) => (c, None),
        Err(e) => (Vec::new(), Some(e)),
    };
    if let Some(e) = claims_error {
        let _ = writeln!(h, "<p class=\"warn\">The papers' claims could not be read: {}</p>", esc(&e.to_string()));
    }
    changes_section(&mut h, run_dir, meta.as_ref(), summaries, plots, batch, &claims);
    history_link(&mut h, run_dir, meta.as_ref(), name);
    timing_section(&mut h, summaries, batch);
    provenance::hardware_note(&mut h, meta.as_ref());
    let references: Vec<crate::judge::reference::GroupReference> = meta
        .as_ref()
        .and_then(|m| m.references.clone())
        .and_then(|r| serde_json::from_value(r).ok())
        .unwrap_or_default();
    status_matrix(&mut h, run_dir, summaries, plots, &external, &references);
    external_section(&mut h, &external, summaries);
    tables_section(&mut h, run_dir, tables, plots, summaries);
    claims::claims_section(&mut h, &claims);
    plots_section(&mut h, run_dir, plots);
    files_section(&mut h, run_dir, summaries, tables)?;
    provenance_section(&mut h, meta.as_ref());
    h += "</body>\n</html>\n";
    write_atomic(&run_dir.join("index.html"), h.as_bytes())
}

/// The link to the trend page of this config's history, when the batch was appended to one
/// and the page rendered (`meta.json`'s `history_outcome`, set by `run` and `merge` before the
/// report); relative, so the folders can move together.
fn history_link(h: &mut String, run_dir: &Path, meta: Option<&Meta>, name: &str) {
    let outcome = meta.and_then(|m| m.history_outcome.clone());
    let Some(outcome) = outcome.and_then(|o| serde_json::from_value::<crate::history::HistoryOutcome>(o).ok()) else {
        return;
    };
    let Some((db, _, Some(page))) = outcome.in_history() else { return };
    let _ = writeln!(
        h,
        "<p>History: <a href=\"{}\">trend of {} over its batches</a> (database <code>{}</code>)</p>",
        href(&crate::paths::relative_link(run_dir, page)),
        esc(name),
        esc(&db.display().to_string())
    );
}

/// The papers' claims this batch's config answers (none without a config name).
fn papers_claims(
    run_dir: &Path,
    summaries: &[SummaryRow],
    batch: &Batch,
) -> Result<Vec<crate::claims::Evaluated>, crate::claims::ClaimsError> {
    let Some(config) = batch.config.clone() else { return Ok(Vec::new()) };
    let folder = crate::claims::Folder { config, dir: run_dir.to_path_buf(), rows: summaries.to_vec() };
    crate::claims::for_folder(&folder)
}

/// `meta.json`, or `None` when the folder has none (e.g. written by an older version).
fn read_meta(run_dir: &Path) -> Result<Option<Meta>> {
    if !crate::run_folder::meta_json(run_dir).exists() {
        return Ok(None);
    }
    Ok(Some(Meta::read(run_dir)?))
}
