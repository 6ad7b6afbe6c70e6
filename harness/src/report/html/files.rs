//! Links to the folder's files: the summary, meta.json and each table's four twins by name,
//! the per-run files by their folders (hundreds of names would outweigh the page).

use crate::escape::{esc, href};
use crate::report::tables::Table;
use crate::run_folder::SummaryRow;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// Sorted file names (relative to `run_dir`) in `sub` with extension `ext`; empty when absent.
pub(super) fn list_files(run_dir: &Path, sub: &str, ext: &str) -> Result<Vec<String>> {
    let dir = run_dir.join(sub);
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    for entry in std::fs::read_dir(&dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let entry = entry.with_context(|| format!("{}: cannot list", dir.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        // Skip write_atomic's temporaries (`.name.tmpPID`).
        if name.ends_with(&format!(".{ext}")) && !name.starts_with('.') {
            out.push(format!("{sub}/{name}"));
        }
    }
    out.sort();
    Ok(out)
}

/// The folder's files of this batch: its tables, and the runs' and meshes' files of the runs
/// in the summary (an interrupted run's partial repeats, or any other file, are not listed).
pub(super) fn files_section(
    h: &mut String,
    run_dir: &Path,
    summaries: &[SummaryRow],
    tables: &[(String, Table)],
) -> Result<()> {
    let stems: std::collections::HashSet<String> =
        summaries.iter().map(|s| crate::run_folder::run_stem(&s.dataset, &s.energy, &s.solver)).collect();
    let datasets: std::collections::HashSet<&str> = summaries.iter().map(|s| s.dataset.as_str()).collect();
    // `runs/<stem>.csv`, `uv/<stem>.uv.gz`, `meshes/<dataset>.obj.gz`: the name up to its extension.
    let of_batch = |f: &String, ext: &str| {
        let name = f.rsplit('/').next().unwrap_or(f);
        let base = name.strip_suffix(&format!(".{ext}")).unwrap_or(name);
        stems.contains(base) || datasets.contains(base)
    };
    *h += "<h2 id=\"files\">Files</h2>\n";
    let link = |f: &str| format!("<li><a href=\"{}\">{}</a></li>\n", href(f), esc(f));
    *h += "<ul class=\"files\">\n";
    for f in ["summary.csv", "meta.json"] {
        if run_dir.join(f).exists() {
            *h += &link(f);
        }
    }
    for (stem, _) in tables {
        for ext in ["csv", "md", "html", "tex"] {
            *h += &link(&format!("tables/{stem}.{ext}"));
        }
    }
    *h += "</ul>\n<ul>\n";
    for (title, sub, ext) in [
        ("Per-iteration CSVs", "runs", "csv"),
        (
            "Final maps (UVs only: mapbench map RUN_DIR RUN --obj FILE joins one with its mesh into an OBJ)",
            "uv",
            "uv.gz",
        ),
        ("Meshes of the maps (gzip OBJ)", "meshes", "obj.gz"),
        ("Final maps of an older folder (OBJ: source mesh as v, map as vt)", "uv", "obj"),
    ] {
        let files = list_files(run_dir, sub, ext)?.into_iter().filter(|f| of_batch(f, ext)).count();
        if files == 0 && sub != "runs" {
            continue;
        }
        // The folder, not its hundreds of names: the status matrix links each run's CSV.
        let _ = writeln!(
            h,
            "<li>{}: {files} <code>.{}</code> files in <a href=\"{}/\">{}/</a></li>",
            esc(title),
            esc(ext),
            href(sub),
            esc(sub)
        );
    }
    *h += "</ul>\n";
    Ok(())
}
