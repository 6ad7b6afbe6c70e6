//! Verdicts that hold, end to end: a batch judged against a stored reference that a run of it
//! beats lowers the store for the next batch; a subset of the solvers gets the same verdicts;
//! the build's provenance is the binary's.

use crate::common;

use common::{mapbench, read_csv, text, write_config, QUAD_OBJ};
use mapbench::judge::problem::Problem;
use mapbench::judge::reference::store::{map_checksum, Store};
use mapbench::plan::{config::LoadedConfig, Plan};
use std::path::Path;

/// A fan of four triangles around a lifted centre (a disk with one interior vertex) and a
/// bumpier one: small problems whose references take a second.
const FAN: &str =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 0.4\nv 0.5 0 0.1\nf 1 6 5\nf 6 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n";

fn config(dir: &Path, solvers: &str) -> std::path::PathBuf {
    write_config(
        dir,
        &format!(
            "name = \"refs\"\nreferences = \"refs.json\"\nenergies = [\"sd\", \"bconf\"]\nsolvers = [{solvers}]\n\
             [[dataset]]\nname = \"fan\"\npath = \"fan.obj\"\n"
        ),
    )
}

/// `(solver, energy) -> (verdict, final_gap, ref_energy)` of a run folder.
fn verdicts(out: &Path) -> Vec<(String, String, String, String, String)> {
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    rows.iter()
        .map(|r| {
            (
                r[col("solver")].clone(),
                r[col("energy")].clone(),
                r[col("verdict")].clone(),
                r[col("final_gap")].clone(),
                r[col("ref_energy")].clone(),
            )
        })
        .collect()
}

#[test]
fn a_run_below_the_stored_reference_lowers_it_and_verdicts_do_not_depend_on_the_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("fan.obj"), FAN).unwrap();
    let all = config(dir, "\"kp-newton\", \"slim\", \"lbfgs\"");
    let o = mapbench(&["references", all.to_str().unwrap()], dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The store's SD entry replaced by a valid but worse one: the start map, its energy.
    let store_path = dir.join("refs.json");
    let plan = Plan::resolve(LoadedConfig::load(&all).unwrap(), &["fan__sd__kp-newton".to_string()]).unwrap();
    let problem = Problem::of(&plan, &plan.runs[0]).unwrap();
    let mut store = Store::read(&store_path).unwrap();
    let key = mapbench::judge::reference::key(&plan, &plan.runs[0]).unwrap();
    let e_star = store.entries[&key].e_star;
    let maps = store.maps();
    let worse = store.entries.get_mut(&key).unwrap();
    (worse.e_star, worse.map_checksum) = (problem.e0, map_checksum(&problem.x0));
    let map = maps.join(&worse.map);
    std::fs::write(&map, mapbench::run_folder::map::encode_uv(&problem.mesh, &problem.x0)).unwrap();
    store.write().unwrap();

    // The batch: every run ends below it; the lowest lowers the store before the judge.
    let out = dir.join("n1");
    let o = mapbench(&["run", all.to_str().unwrap(), "--out", out.to_str().unwrap(), "--repeat", "1"], dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("below E* = ") && text(&o).contains("polishing and certifying it"), "{}", text(&o));
    let lowered = Store::read(&store_path).unwrap().entries[&key].clone();
    assert!((lowered.e_star - e_star).abs() <= 1e-9 * e_star, "{} vs {e_star}", lowered.e_star);
    assert!(lowered.certificate.certified);
    let run_step = lowered.provenance.iter().find(|s| s.batch.is_some()).expect("the run is the provenance");
    assert!(run_step.batch.as_ref().unwrap().run.starts_with("fan__sd__"), "{run_step:?}");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    let sd = meta["references"].as_array().unwrap().iter().find(|g| g["energy"] == "sd").unwrap().clone();
    assert_eq!(sd["origin"], "improved", "{sd}");
    // provenance of the code: the binary's build, the config folder's revision apart
    assert_eq!(meta["git_revision"].as_str().map(str::to_string), env_revision());
    assert!(meta.get("config_git_revision").is_none(), "the temporary folder is no checkout: {meta}");
    let first = verdicts(&out);
    for v in first.iter().filter(|v| v.1 == "sd") {
        let judged: f64 = v.4.parse().unwrap();
        assert_eq!((judged, v.2.is_empty()), (lowered.e_star, false), "{v:?}");
    }

    // A run ends at the target of the reference it started with: with the worse E* (the
    // start's energy) that is where its rule first holds; a run that stopped there above the
    // lowered reference's target says so.
    let stopped = first.iter().filter(|v| v.1 == "sd" && v.2 != "solved").count();
    assert!(
        first.iter().filter(|v| v.1 == "sd").all(|v| v.2 == "solved" || v.2 == "stopped_above_target"),
        "{first:?}"
    );

    // The next batch reads the lowered reference: nothing lowers it again, and every run goes
    // on to its target; the runs solved before stay solved at the same E*.
    let again = dir.join("n2");
    let o = mapbench(&["run", all.to_str().unwrap(), "--out", again.to_str().unwrap(), "--repeat", "1"], dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!text(&o).contains("below E* = "), "{}", text(&o));
    let second = verdicts(&again);
    for (a, b) in first.iter().zip(&second) {
        assert_eq!((&a.0, &a.1, &a.4), (&b.0, &b.1, &b.4), "the same runs against the same E*");
        assert!(a.2 != "solved" || b.2 == "solved", "{a:?} then {b:?}");
    }
    let now = second.iter().filter(|v| v.1 == "sd" && v.2 != "solved").count();
    assert!(now <= stopped, "{second:?}");

    // A subset of the solvers: the same verdicts, gaps and E* for those solvers.
    let one = config(dir, "\"slim\"");
    let sub = dir.join("n3");
    let o = mapbench(&["run", one.to_str().unwrap(), "--out", sub.to_str().unwrap(), "--repeat", "1"], dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let slim: Vec<_> = second.iter().filter(|v| v.0 == "slim").cloned().collect();
    assert_eq!(verdicts(&sub), slim);

    // A hand edit is refused, and the reference computed again.
    let mut store = Store::read(&store_path).unwrap();
    store.entries.get_mut(&key).unwrap().e_star -= 1e-3;
    store.write().unwrap();
    let o = mapbench(&["references", all.to_str().unwrap()], dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("refused: e_star = ") && text(&o).contains("but its map's energy is"), "{}", text(&o));
}

/// The revision this test binary was built from, as the harness's build script saw it.
fn env_revision() -> Option<String> {
    let rev = std::process::Command::new("git").args(["rev-parse", "HEAD"]).output().ok()?;
    rev.status.success().then(|| String::from_utf8_lossy(&rev.stdout).trim().to_string())
}

/// A reference's budget is at least any committed config's `max_iters`: a run of a batch
/// cannot go past the iterations its reference had (each config's `[stop] max_iters`, 1000 by
/// default).
#[test]
fn the_reference_budget_covers_every_committed_config() {
    let configs = common::repo_root().join("configs");
    let mut seen = 0;
    for entry in std::fs::read_dir(&configs).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let table: toml::Table = std::fs::read_to_string(&path).unwrap().parse().unwrap();
        let max_iters = table.get("stop").and_then(|s| s.get("max_iters")).and_then(|m| m.as_integer()).unwrap_or(1000);
        assert!(
            max_iters as usize <= mapbench::judge::reference::computation::BUDGET,
            "{}: max_iters = {max_iters} is past the reference budget",
            path.display()
        );
        seen += 1;
    }
    assert!(seen >= 10, "{seen} configs");
}

/// `references` lists a config's reference minima: the committed seed's, the ones it computes
/// (added to the store, found there next time) and the ones it cannot have (exit 1).
#[test]
fn references_computes_what_no_store_holds_and_lists_every_group() {
    let tmp = tempfile::tempdir().unwrap();
    let fan = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 0.3\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n";
    std::fs::write(tmp.path().join("fan.obj"), fan).unwrap();
    let body = "name = \"t\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"cm\"]\n\
                [[dataset]]\nname = \"fan\"\npath = \"fan.obj\"\n";
    let cfg = write_config(tmp.path(), body);
    let store = tmp.path().join("refs.json");
    let list = |cfg: &Path| {
        let o = mapbench(&["references", cfg.to_str().unwrap(), "--store", store.to_str().unwrap()], tmp.path());
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        let rows: Vec<Vec<String>> = out.lines().skip(1).map(|l| l.split('\t').map(String::from).collect()).collect();
        (o.status.code(), rows, text(&o))
    };
    let (code, rows, log) = list(&cfg);
    assert_eq!(code, Some(0), "{log}");
    let origins: Vec<(&str, &str, &str)> = rows.iter().map(|r| (r[0].as_str(), r[3].as_str(), r[4].as_str())).collect();
    assert_eq!(origins, [("bumpy_1k", "yes", "Seed"), ("fan", "yes", "Computed")], "{log}");
    assert!(log.contains("reference minimum of fan param sd: computing"), "{log}");
    let e_star: f64 = rows[1][2].parse().unwrap();
    assert!(e_star.is_finite() && e_star >= 2.0, "SD is at least 2: {e_star}");
    // the next call finds it in the store, and computes nothing
    let (code, rows, log) = list(&cfg);
    assert_eq!((code, rows[1][4].as_str(), rows[1][2].parse::<f64>().unwrap()), (Some(0), "Store", e_star), "{log}");
    assert!(!log.contains("computing"), "{log}");
    // a mesh that does not load has no reference: listed as such, exit 1
    std::fs::write(tmp.path().join("fan.obj"), QUAD_OBJ).unwrap();
    let (code, rows, log) = list(&cfg);
    assert_eq!((code, rows[1][2].as_str(), rows[1][4].as_str()), (Some(1), "-", "Unavailable"), "{log}");
    // an authalic config has them too: the normalized authalic energy's minimum from the
    // stretch start, by AEM-CG; a flat disk is its own area-preserving map (E_A = 0)
    let authalic = write_config(
        tmp.path(),
        "name = \"a\"\ntask = \"authalic\"\ndatasets = [\"flat_disk_1k\"]\nsolvers = [\"sem\"]\n",
    );
    let (code, rows, log) = list(&authalic);
    assert_eq!(
        (code, rows.first().map(|r| (r[1].as_str(), r[3].as_str(), r[4].as_str()))),
        (Some(0), Some(("authalic", "yes", "Computed"))),
        "{log}"
    );
    let e_star: f64 = rows[0][2].parse().unwrap();
    assert!((0.0..1e-10).contains(&e_star), "{log}");
}

/// KP-Newton's exp-SD run on the generated `finger_1k` ends at another minimum, 8.7e-4 of the
/// span above the committed reference (SLIM's): its line search finds no decrease where the
/// Newton decrement is at round-off (`round_off`, a stationary end, not a breakdown), and the
/// polish from its map stays there, so the verdict is `other_minimum` at 1e-6, not `broke_down`.
#[test]
fn a_newton_run_at_round_off_above_the_reference_ends_at_another_minimum() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let cfg = write_config(
        dir,
        "name = \"roundoff\"\ndatasets = [\"finger_1k\"]\nenergies = [\"exp-sd\"]\nsolvers = [\"kp-newton\"]\n\
         compute_references = false\n[energy.exp-sd]\ns = 1.0\n",
    );
    let out = dir.join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], dir);
    assert_eq!(o.status.code(), Some(0), "an unsolved run is not a failed one: {}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let r = &rows[0];
    assert_eq!(r[col("ref_source")], "reference", "the committed store's E*: {r:?}");
    assert_eq!((r[col("stop_reason")].as_str(), r[col("verdict")].as_str()), ("round_off", "other_minimum"), "{r:?}");
    let num = |n: &str| r[col(n)].parse::<f64>().unwrap();
    assert!((num("final_gap") - 8.7e-4).abs() < 1e-5, "{r:?}");
    // the polish stayed: it moved the energy by round-off only
    assert!((num("polished_energy") - num("final_energy")).abs() <= 1e-9 * num("final_energy"), "{r:?}");
}
