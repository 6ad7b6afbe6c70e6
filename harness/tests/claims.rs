//! The papers' claims end to end: a small batch of the `papers` config decides the Table 4
//! claims, `mapbench claims` prints them, the report has their section; the same folder with
//! `kp-newton`'s iterations made ten times larger turns the claims about KP to "not held", and
//! once both batches are in the history the second's first screen says which stopped holding.

use crate::common;

use common::{mapbench, text, write_config};
use mapbench::history::{Decision, HistoryOutcome};
use serde_json::Value;
use std::path::Path;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

/// `summary.csv` with `kp-newton`'s iterations, to its stop and to each target, times ten.
fn ten_times_kp_iterations(dir: &Path) {
    let path = dir.join("summary.csv");
    let mut r = csv::Reader::from_path(&path).unwrap();
    let head = r.headers().unwrap().clone();
    let solver = head.iter().position(|h| h == "solver").unwrap();
    let cols: Vec<usize> = head
        .iter()
        .enumerate()
        .filter(|(_, h)| {
            *h == "iterations" || h.starts_with("iters_to_") || h.starts_with("rule_") && h.ends_with("_iters")
        })
        .map(|(i, _)| i)
        .collect();
    assert!(cols.len() >= 2, "iterations and iterations to a target: {head:?}");
    let mut w = csv::Writer::from_path(dir.join("summary.tmp")).unwrap();
    w.write_record(&head).unwrap();
    for rec in r.records() {
        let rec = rec.unwrap();
        let row: Vec<String> = rec
            .iter()
            .enumerate()
            .map(|(i, v)| match v.parse::<usize>() {
                Ok(n) if rec[solver] == *"kp-newton" && cols.contains(&i) => (n * 10).to_string(),
                _ => v.to_string(),
            })
            .collect();
        w.write_record(&row).unwrap();
    }
    w.flush().unwrap();
    std::fs::rename(dir.join("summary.tmp"), &path).unwrap();
}

fn claims(dir: &Path, tmp: &Path) -> Vec<Value> {
    let o = mapbench(&["claims", dir.to_str().unwrap(), "--json"], tmp);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    serde_json::from_slice::<Value>(&o.stdout).unwrap().as_array().unwrap().clone()
}

/// The outcome of claim `id` by `rule` (`paper` or `verdict`).
fn outcome<'a>(all: &'a [Value], id: &str, rule: &str) -> Option<&'a str> {
    let c = all.iter().find(|c| c["id"] == id)?;
    c["rules"].as_array()?.iter().find(|j| j["rule"] == rule)?["outcome"].as_str()
}

/// The Table 4 claims about KP's iterations on the energies of the test's batch (SD, BCONF):
/// `kp-newton` needs fewer than the others.
fn kp_iteration_claims(all: &[Value]) -> Vec<String> {
    all.iter()
        .filter(|c| {
            c["id"].as_str().unwrap().starts_with("golla2018/t4-kp")
                && ["sd", "bconf"].contains(&c["energy"].as_str().unwrap())
                && c["metric"] == "iterations"
                && ["fewest", "less"].contains(&c["check"].as_str().unwrap())
        })
        .map(|c| c["id"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn claims_are_decided_on_a_papers_batch_and_ten_times_kps_iterations_break_the_table_4_claims() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let cfg = write_config(
        t,
        "name = \"papers\"\ntask = \"param\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\", \"bconf\"]\n\
         solvers = [\"kp-newton\", \"fp-newton-4x4\", \"cm\", \"akvf\"]\n[stop]\nmax_iters = 300\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "a", "--history", "h.sqlite"], t);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let a = t.join("a");
    let before = claims(&a, t);
    // every committed claim is listed; those of other configs are not measurable and say why
    assert!(before.len() >= 12);
    assert_eq!(outcome(&before, "golla2018/t6-akvf-most-iterations-deform", "paper"), Some("not_measurable"));
    let deform = before.iter().find(|c| c["id"] == "golla2018/t6-akvf-most-iterations-deform").unwrap();
    assert!(deform["rules"][0]["why"].as_str().unwrap().contains("papers_deform"), "{deform}");
    // the Table 4 claims about KP are decided on this folder, both rules, with our numbers
    let about_kp = kp_iteration_claims(&before);
    assert!(about_kp.len() >= 2, "{about_kp:?}");
    for id in &about_kp {
        let got = outcome(&before, id, "paper").unwrap();
        assert!(["held", "not_held"].contains(&got), "{id}: {got}");
        // by the verdict too (two solvers that never reached the target cannot be ordered)
        assert!(outcome(&before, id, "verdict").is_some(), "{id}");
        let c = before.iter().find(|c| c["id"] == *id).unwrap();
        assert!(c["rules"][0]["ours"]["kp-newton"].as_f64().is_some(), "{c}");
        assert!(c["published"]["kp-newton"].as_f64().is_some(), "{c}");
    }

    // the report has the section and a line on the first screen
    let page = std::fs::read_to_string(a.join("index.html")).unwrap();
    assert!(page.contains("<h2 id=\"claims\">") && page.contains("<a href=\"#claims\">Papers' claims</a>"));
    assert!(page.contains("id=\"claim-golla2018-t4-kp-fewest-iterations-bconf\""));
    // text and Markdown say the same outcomes
    let o = mapbench(&["claims", a.to_str().unwrap(), "--markdown"], t);
    let md = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(md.starts_with("| claim |") && md.contains("`golla2018/t4-kp-fewest-iterations-bconf`"), "{md}");

    // ten times KP's iterations: every Table 4 claim about them is not held, by both rules
    let b = t.join("b");
    copy_dir(&a, &b);
    ten_times_kp_iterations(&b);
    let after = claims(&b, t);
    for id in &about_kp {
        assert_eq!(outcome(&after, id, "paper"), Some("not_held"), "{id}");
        // by the verdict a run that never reached the target stays there
        assert_ne!(outcome(&after, id, "verdict"), Some("held"), "{id}");
    }
    // what held and holds no longer: AKVF is no longer the slowest, at least
    let ids: Vec<&str> = before.iter().map(|c| c["id"].as_str().unwrap()).collect();
    let lost: Vec<&str> = ids
        .into_iter()
        .filter(|id| outcome(&before, id, "paper") == Some("held") && outcome(&after, id, "paper") != Some("held"))
        .collect();
    assert!(lost.contains(&"golla2018/t4-akvf-most-iterations"), "{lost:?}");
    // in the history after the first batch, the second's first screen names what stopped
    // holding. The report refuses b (its summary no longer matches its iteration files), so
    // the page is rendered in c, a copy of a whose meta.json says it is b's batch: the
    // changes are read from the database.
    let (mut recorded, _) = HistoryOutcome::conclude(Some(&t.join("h.sqlite")), &b, &b, Decision::Append);
    recorded.set_trend(Ok(t.join("trend.html")));
    let c = t.join("c");
    copy_dir(&a, &c);
    recorded.write_into(&c).unwrap();
    let o = mapbench(&["report", c.to_str().unwrap()], t);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let page = std::fs::read_to_string(c.join("index.html")).unwrap();
    let warn = page.split("of the papers' claims stopped holding").nth(1).expect("a line on what stopped holding");
    let warn = warn.split("</p>").next().unwrap();
    for id in lost {
        assert!(warn.contains(id), "{id} is named: {warn}");
    }
}
