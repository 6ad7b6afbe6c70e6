//! The external solvers of a batch (`meta.json`'s `external`): what ran them, which version,
//! how many of their maps the harness recomputed, and why any were skipped.

use crate::escape::esc;
use crate::external::probe::Probe;
use crate::run_folder::meta::Meta;
use crate::run_folder::{Status, SummaryRow};
use std::fmt::Write as _;

/// The batch's external solvers as `meta.json` records them (none for an older folder).
pub(super) fn probes(meta: Option<&Meta>) -> Vec<Probe> {
    meta.and_then(|m| m.external.clone()).and_then(|v| serde_json::from_value(v).ok()).unwrap_or_default()
}

/// The section, when the batch has external solvers.
pub(super) fn external_section(h: &mut String, probes: &[Probe], summaries: &[SummaryRow]) {
    if probes.is_empty() {
        return;
    }
    *h += "<h2 id=\"external\">External solvers</h2>\n<p class=\"caption\">Solvers outside the catalogue, run as \
           processes under the external-solver protocol (peers/PROTOCOL.md) from the same start map as ours. \
           Every map they wrote was read back and its energy, gradient norm and flips recomputed by mapbench's \
           code; a reported energy that disagreed beyond round-off failed the run. Their time_s is the \
           process's wall time on the harness's clock (interpreter start-up included, record writing left \
           out); their per-iteration times are their own clock's; cpu_s and peak_rss_mb are their own \
           processes'. Each ran in a sandbox (the book's security page): it could write only in its problem \
           folder, read only its own files and the system's, not trace or signal the harness, not use the \
           network, and every process it started ended with its run; the table names the protections that \
           held in all its runs and those the kernel did not give.</p>\n\
           <table>\n<tr><th>solver</th><th>version</th><th>command</th><th>ran</th><th>failed</th>\
           <th>skipped</th><th>maps verified</th><th>confined</th></tr>\n";
    for p in probes {
        let mine: Vec<&SummaryRow> = summaries.iter().filter(|s| s.solver == p.name).collect();
        let n = |st: Status| mine.iter().filter(|s| s.status == st).count();
        let verified: usize = mine.iter().filter_map(|s| s.verified_snapshots).sum();
        let confined = protections(&mine);
        let version = match (&p.version, &p.unavailable) {
            (_, Some(why)) => format!("unavailable: {why}"),
            (Some(v), None) => v.clone(),
            (None, None) => "not recorded (no version command)".into(),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{verified}</td><td>{}</td></tr>",
            esc(&p.name),
            esc(&version),
            esc(&p.command.join(" ")),
            n(Status::Ok) + n(Status::NotConverged) + n(Status::Budget),
            n(Status::Failed),
            n(Status::Skipped),
            esc(&confined),
        );
    }
    *h += "</table>\n";
}

/// The protections that held in every run of a solver that ran, and those missing from some.
fn protections(runs: &[&SummaryRow]) -> String {
    use crate::external::confine::Protection;
    let listed: Vec<&str> = runs.iter().filter_map(|s| s.confined.as_deref()).collect();
    if listed.is_empty() {
        return "no run".into();
    }
    let held = |p: &Protection| listed.iter().filter(|l| l.split(' ').any(|w| w == p.as_str())).count();
    let all: Vec<&str> = Protection::ALL.iter().filter(|p| held(p) == listed.len()).map(|p| p.as_str()).collect();
    let some: Vec<String> = Protection::ALL
        .iter()
        .filter(|p| held(p) < listed.len())
        .map(|p| format!("{} (missing in {} of {})", p.as_str(), listed.len() - held(p), listed.len()))
        .collect();
    match (all.is_empty(), some.is_empty()) {
        (_, true) => format!("all: {}", all.join(", ")),
        (true, false) => format!("none; not: {}", some.join(", ")),
        (false, false) => format!("{}; not: {}", all.join(", "), some.join(", ")),
    }
}

/// The first screen's warning when a protection of the sandbox was missing from an external run
/// (the kernel lacked it, or the run used more CPU than its threads): which, in how many runs.
pub(super) fn sandbox_warning(h: &mut String, summaries: &[SummaryRow]) {
    use crate::external::confine::Protection;
    let listed: Vec<&str> = summaries.iter().filter_map(|s| s.confined.as_deref()).collect();
    let missing: Vec<String> = Protection::ALL
        .iter()
        .map(|p| (p, listed.iter().filter(|l| !l.split(' ').any(|w| w == p.as_str())).count()))
        .filter(|&(_, n)| n > 0)
        .map(|(p, n)| format!("{} in {n}", p.as_str()))
        .collect();
    if missing.is_empty() {
        return;
    }
    let not_whole = listed.iter().filter(|l| Protection::ALL.iter().any(|p| !l.split(' ').any(|w| w == p.as_str())));
    let _ = writeln!(
        h,
        "<p class=\"warn\">The sandbox was not whole in {} of {} external runs (missing: {}): see \
         <a href=\"#external\">External solvers</a> and the batch's log for why.</p>",
        not_whole.count(),
        listed.len(),
        esc(&missing.join(", "))
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(solver: &str, confined: Option<&str>) -> SummaryRow {
        SummaryRow {
            solver: solver.into(),
            status: Status::Ok,
            confined: confined.map(Into::into),
            ..Default::default()
        }
    }

    #[test]
    fn a_protection_missing_from_some_runs_is_named_in_the_table_and_on_the_first_screen() {
        let whole = "writes reads tracing signals network unix_sockets ipc limits threads";
        let no_sockets = "writes reads tracing signals network ipc limits threads";
        let runs = [run("p", Some(whole)), run("p", Some(no_sockets)), run("q", Some(whole)), run("kp-newton", None)];
        let p: Vec<&SummaryRow> = runs.iter().filter(|r| r.solver == "p").collect();
        assert_eq!(
            protections(&p),
            "writes, reads, tracing, signals, network, ipc, limits, threads; not: unix_sockets (missing in 1 of 2)"
        );
        assert!(protections(&[&runs[3]]).starts_with("no run"));
        let mut h = String::new();
        sandbox_warning(&mut h, &runs);
        assert!(h.contains("not whole in 1 of 3 external runs (missing: unix_sockets in 1)"), "{h}");
        let mut h = String::new();
        sandbox_warning(&mut h, &runs[2..]);
        assert!(h.is_empty(), "{h}");
    }
}
