//! The report's provenance section, from `meta.json`.

use crate::escape::esc;
use crate::run_folder::meta::{shown, Meta};
use crate::utc::utc;
use std::fmt::Write as _;

/// When the shards of a merged folder ran on different machines: a visible warning naming
/// them, since only `time_norm` (each shard's times over its own calibration) compares then.
pub(super) fn hardware_note(h: &mut String, meta: Option<&Meta>) {
    let Some(shards) = meta.and_then(|m| m.merged_from.as_ref()) else { return };
    let known: Vec<(&str, &crate::hardware::Hardware)> = shards
        .iter()
        .filter_map(|s| Some((s.shard.as_deref().unwrap_or(s.dir.as_str()), s.hardware.as_ref()?)))
        .collect();
    let machines = crate::hardware::distinct(known);
    if machines.len() < 2 {
        return;
    }
    let list: Vec<String> = machines
        .iter()
        .map(|(hw, names)| {
            format!("{} ran shard{} {}", hw.describe(), if names.len() == 1 { "" } else { "s" }, names.join(", "))
        })
        .collect();
    let _ = writeln!(
        h,
        "<p class=\"warn\" id=\"hardware\"><b>The shards ran on {} different machines:</b> {}. Their time_s do not \
         compare across shards; time_norm (each shard's times over its own machine calibration) is the comparable \
         time, and the tables and profiles use it when every run has one.</p>",
        machines.len(),
        esc(&list.join("; "))
    );
}

/// The first screen's line of where the numbers come from: the binary's revision, when the
/// batch started, the machine and the config file, with a link to the whole provenance.
pub(super) fn glance(h: &mut String, meta: Option<&Meta>) {
    let Some(m) = meta else { return };
    let revision = match (shown(&m.git_revision), m.git_dirty) {
        (Some(r), Some(true)) => {
            format!("revision <code>{}</code> with uncommitted changes", esc(r.get(..7).unwrap_or(&r)))
        }
        (Some(r), _) => format!("revision <code>{}</code>", esc(r.get(..7).unwrap_or(&r))),
        (None, _) => "revision unknown".to_string(),
    };
    let mut parts = vec![revision];
    parts.extend(m.started_unix.map(|s| format!("started {}", esc(&utc(s)))));
    parts.extend(m.hardware.as_ref().map(|hw| esc(&hw.describe())));
    parts.extend(shown(&m.config_path).map(|c| format!("<code>{}</code>", esc(&c))));
    let _ = writeln!(h, "<p class=\"caption\">{} (<a href=\"#provenance\">provenance</a>)</p>", parts.join(", "));
}

pub(super) fn provenance_section(h: &mut String, meta: Option<&Meta>) {
    *h += "<h2 id=\"provenance\">Provenance</h2>\n";
    let Some(m) = meta else {
        *h += "<p>No meta.json in this folder.</p>\n";
        return;
    };
    let mut rows: Vec<(&str, String)> = Vec::new();
    if let Some(rev) = shown(&m.git_revision) {
        let dirty = match m.git_dirty {
            Some(true) => " (dirty: uncommitted changes)",
            Some(false) => " (clean)",
            None => "",
        };
        rows.push(("git revision", format!("{rev}{dirty}")));
    } else {
        rows.push(("git revision", "unknown (not a git checkout)".into()));
    }
    for (label, value) in [
        ("mapbench version", shown(&m.mapbench_version)),
        ("rustc", shown(&m.rustc)),
        ("crates", shown(&m.crates)),
        ("config file", shown(&m.config_path)),
        ("host", shown(&m.host)),
        ("machine", m.hardware.as_ref().map(|h| h.describe())),
        ("memory", m.hardware.as_ref().and_then(|h| h.memory_mb).map(|mb| format!("{mb} MiB"))),
        ("operating system", m.hardware.as_ref().and_then(|h| h.os.clone())),
        ("cores", shown(&m.cores)),
        ("--jobs", shown(&m.jobs)),
        ("threads per run", shown(&m.threads_per_run)),
        ("linear ordering", shown(&m.linear_ordering)),
        ("shard", shown(&m.shard)),
        ("meshes folder", shown(&m.meshes_dir)),
        ("--only", shown(&m.only)),
        ("--resume", shown(&m.resume)),
        ("interrupted", shown(&m.interrupted)),
    ] {
        if let Some(v) = value {
            rows.push((label, v));
        }
    }
    if let Some(s) = m.started_unix {
        rows.push(("started", utc(s)));
    }
    match (m.started_unix, m.ended_unix) {
        (Some(s), Some(e)) => rows.push(("ended", format!("{} ({} s)", utc(e), e.saturating_sub(s)))),
        (_, None) => rows.push(("ended", "not recorded (interrupted or still running)".into())),
        _ => {}
    }
    *h += "<dl>\n";
    for (k, v) in rows {
        let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), esc(&v));
    }
    *h += "</dl>\n";
    // Linked, not inlined: the whole record (config, references, calibration) is tens of KB.
    *h += "<p>Everything else the batch recorded (the resolved config, the references, the calibration): \
           <a href=\"meta.json\">meta.json</a>.</p>\n";
}
