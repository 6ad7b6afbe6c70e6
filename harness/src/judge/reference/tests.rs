use super::store::{map_checksum, Book, Store};
use super::*;
use crate::judge::improve;
use crate::plan::config::LoadedConfig;
use std::cell::RefCell;
use std::path::Path;

/// A fan of four triangles around a lifted centre: a disk with one interior vertex.
fn fan(z: f64) -> String {
    format!("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 {z}\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n")
}

/// The plan of a config in `dir` on the inline dataset `name` (`m.obj`), storing references
/// in `refs.json`.
fn plan(dir: &Path, name: &str, energies: &str, extra: &str) -> Plan {
    let text = format!(
        "name = \"t\"\nreferences = \"refs.json\"\nenergies = [{energies}]\nsolvers = [\"kp-newton\", \"slim\"]\n\
         [[dataset]]\nname = {name:?}\npath = \"m.obj\"\n{extra}"
    );
    Plan::resolve(LoadedConfig::parse(&text, &dir.join("c.toml")).unwrap(), &[]).unwrap()
}

/// What `prepare` made of `plan`'s groups, with the notices it gave.
fn prepared_plan(plan: &Plan) -> (Vec<GroupReference>, Vec<String>) {
    let runs: Vec<&PlannedRun> = plan.runs.iter().collect();
    let notices = RefCell::new(Vec::new());
    let groups =
        prepare(plan, &runs, &|line| notices.borrow_mut().push(line.to_string()), &AtomicBool::new(false)).unwrap();
    (groups, notices.into_inner())
}

fn prepared(dir: &Path, name: &str, energies: &str, extra: &str) -> (Vec<GroupReference>, Vec<String>) {
    prepared_plan(&plan(dir, name, energies, extra))
}

/// A reference is computed once and found again by what determines it: the mesh's content
/// (not the dataset's name), the task and the energy with its parameters; a changed mesh or
/// parameter computes another.
#[test]
fn the_store_is_reused_and_a_changed_mesh_or_energy_parameter_computes_anew() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let (first, notices) = prepared(dir, "m", "\"sd\"", "");
    // one group for both solvers, computed with lines of progress, certified
    assert_eq!(first.len(), 1, "{first:?}");
    assert_eq!(first[0].origin, Origin::Computed);
    assert!(notices[0].contains("computing") && notices.last().unwrap().contains("certified"), "{notices:?}");
    assert!(first[0].certified, "{first:?}");
    let e_star = first[0].e_star.unwrap();
    let stored = Store::read(&dir.join("refs.json")).unwrap();
    assert_eq!(stored.entries.keys().collect::<Vec<_>>(), [first[0].key.as_ref().unwrap()]);
    // the next batch reads it, under another dataset name too
    for name in ["m", "renamed"] {
        let (again, notices) = prepared(dir, name, "\"sd\"", "");
        assert_eq!((again[0].origin, again[0].e_star, &again[0].key), (Origin::Store, Some(e_star), &first[0].key));
        assert!(notices.is_empty(), "{notices:?}");
    }
    // another energy, another parameter: other problems
    let (other, _) = prepared(dir, "m", "\"sd\", \"sarap\"", "[energy.sd]\nsmoothness = 0.25\n");
    assert_eq!(other.iter().map(|g| g.origin).collect::<Vec<_>>(), [Origin::Computed, Origin::Computed]);
    assert!(other.iter().all(|g| g.key != first[0].key) && other[0].key != other[1].key, "{other:?}");
    // the mesh changed: the old reference does not apply
    std::fs::write(dir.join("m.obj"), fan(0.31)).unwrap();
    let (moved, _) = prepared(dir, "m", "\"sd\"", "");
    assert_eq!(moved[0].origin, Origin::Computed);
    assert!(moved[0].key != first[0].key && moved[0].e_star != Some(e_star), "{moved:?}");
    assert_eq!(Store::read(&dir.join("refs.json")).unwrap().entries.len(), 4);
}

/// Each entry carries its map beside the store, how it was found and its certificate, and
/// its `E*` is its map's energy; `E0` and `E_iso` are the group's.
#[test]
fn a_reference_carries_its_map_provenance_and_certificate() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let plan = plan(dir, "m", "\"sd\"", "");
    let (groups, _) = prepared_plan(&plan);
    let store = Store::read(&dir.join("refs.json")).unwrap();
    let r = store.entries.values().next().unwrap();
    assert_eq!(r.map, format!("m__param__sd__{}.uv.gz", r.key));
    assert!(dir.join("refs").join(&r.map).is_file());
    let portfolio: Vec<&str> =
        r.provenance.iter().filter(|s| s.what == StepKind::Portfolio).map(|s| s.solver.as_str()).collect();
    assert_eq!(portfolio, computation::PORTFOLIO, "aqp is defined for sd");
    assert_eq!(r.certificate.rule, CertificateRule::Stationary);
    assert_eq!(
        r.certificate.polishes.iter().map(|p| p.solver.as_str()).collect::<Vec<_>>(),
        ["kp-newton", "lbfgs-laplacian"]
    );
    assert!(r.certificate.polishes.iter().all(|p| p.decrease <= r.certificate.tolerance));
    assert!(r.grad_norm <= computation::STALL_GRAD && r.ideal == 2.0 && r.start == "tutte-scaled");
    let problem = Problem::of(&plan, &plan.runs[0]).unwrap();
    let x = store::verify(r, &store.maps(), &problem).unwrap();
    assert_eq!(problem.measure(&x).energy, r.e_star);
    assert_eq!(map_checksum(&x), r.map_checksum);
    assert_eq!((groups[0].start_energy, groups[0].ideal), (Some(problem.e0), Some(2.0)));
}

/// A stored entry is used only when its map bears it out: an edited `E*`, a missing or
/// altered map, another start are refused with the reason, and the reference is computed
/// again.
#[test]
fn a_hand_edited_store_is_refused_with_the_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let (first, _) = prepared(dir, "m", "\"sd\"", "");
    let path = dir.join("refs.json");
    let original = Store::read(&path).unwrap();
    let edit = |f: &dyn Fn(&mut Reference)| {
        let mut s = Store::read(&path).unwrap();
        s.entries = original.entries.clone();
        s.entries.values_mut().for_each(f);
        s.write().unwrap();
    };
    let e_star = first[0].e_star.unwrap();
    type Edit<'a> = &'a dyn Fn(&mut Reference);
    let cases: [(Edit, &str); 4] = [
        (&|r| r.e_star -= 0.01, "but its map's energy is"),
        (&|r| r.e_star += 0.01, "but its map's energy is"),
        (&|r| r.start_energy *= 2.0, "its common start's energy is"),
        (&|r| r.map_checksum = "0000000000000000".into(), "its map's checksum is"),
    ];
    for (f, why) in cases {
        edit(f);
        let (again, notices) = prepared(dir, "m", "\"sd\"", "");
        assert!(notices.iter().any(|n| n.contains("refused") && n.contains(why)), "{why}: {notices:?}");
        assert_eq!((again[0].origin, again[0].e_star), (Origin::Computed, Some(e_star)), "{why}");
    }
    // the map is gone
    let maps = Store::read(&path).unwrap().maps();
    std::fs::remove_dir_all(&maps).unwrap();
    let (again, notices) = prepared(dir, "m", "\"sd\"", "");
    assert!(notices.iter().any(|n| n.contains("refused") && n.contains("is missing")), "{notices:?}");
    assert_eq!(again[0].origin, Origin::Computed);
}

/// `compute_references = false` computes nothing: the group is judged by the batch's best
/// final energy, with a notice and a note that say why, and nothing counts as missing (no
/// reference job for `submit`); a reference a store holds is still used.
#[test]
fn compute_references_false_computes_nothing_and_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let text = "name = \"t\"\nreferences = \"refs.json\"\ncompute_references = false\nenergies = [\"sd\"]\n\
                solvers = [\"kp-newton\"]\n[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n";
    let off = Plan::resolve(LoadedConfig::parse(text, &dir.join("c.toml")).unwrap(), &[]).unwrap();
    assert!(missing(&off).unwrap().is_empty());
    let (groups, notices) = prepared_plan(&off);
    assert_eq!((groups[0].origin, groups[0].e_star), (Origin::Unavailable, None));
    assert!(groups[0].note.as_deref().unwrap_or("").contains("compute_references = false"), "{groups:?}");
    assert!(notices[0].contains("not computed") && notices[0].contains("best final energy"), "{notices:?}");
    assert!(!dir.join("refs.json").exists(), "nothing written");
    // computed by a batch that may (as `mapbench references` does), then found by this one
    let (on, _) = prepared(dir, "m", "\"sd\"", "");
    let (found, notices) = prepared_plan(&off);
    assert_eq!((found[0].origin, found[0].e_star), (Origin::Store, on[0].e_star));
    assert!(notices.is_empty(), "{notices:?}");
}

/// The store only gets better: a lower entry replaces a higher one, never the reverse; an
/// entry as low but certified replaces an uncertified one. Of the seed and the writable
/// store, the lower verified entry is used; the seed is never written.
#[test]
fn references_only_get_better() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let plan = plan(dir, "m", "\"sd\"", "");
    let (groups, _) = prepared_plan(&plan);
    let problem = Problem::of(&plan, &plan.runs[0]).unwrap();
    let store_path = dir.join("refs.json");
    let stored = Store::read(&store_path).unwrap();
    let r = stored.entries.values().next().unwrap().clone();
    let x = store::verify(&r, &stored.maps(), &problem).unwrap();
    // a higher map (the start's) is not taken; the uncertified copy of the entry neither
    let stores = crate::plan::paths::Stores { seed: None, store: store_path.clone(), persist: true, compute: true };
    let mut book = Book::open(&stores).unwrap();
    let mut higher = r.clone();
    (higher.e_star, higher.map_checksum) = (problem.e0, map_checksum(&problem.x0));
    assert!(!book.add(higher, &problem.x0, &problem.mesh).unwrap());
    let mut uncertified = r.clone();
    uncertified.certificate.certified = false;
    assert!(!book.add(uncertified.clone(), &x, &problem.mesh).unwrap());
    assert_eq!(Store::read(&store_path).unwrap().entries[&r.key], r);
    // as low and certified replaces uncertified
    let mut s = Store::read(&store_path).unwrap();
    s.entries.insert(r.key.clone(), uncertified);
    s.write().unwrap();
    let mut book = Book::open(&stores).unwrap();
    assert!(book.add(r.clone(), &x, &problem.mesh).unwrap());
    // a stale entry (another start: a chained start whose SD minimum moved) is replaced by a
    // higher one from today's start, then the store gets better again
    let mut stale = r.clone();
    stale.start_energy = problem.e0 * 2.0;
    let mut s = Store::read(&store_path).unwrap();
    s.entries.insert(r.key.clone(), stale);
    s.write().unwrap();
    let mut book = Book::open(&stores).unwrap();
    let mut higher = r.clone();
    (higher.e_star, higher.map_checksum) = (problem.e0, map_checksum(&problem.x0));
    assert!(book.add(higher, &problem.x0, &problem.mesh).unwrap(), "a stale entry is replaced");
    assert!(book.add(r.clone(), &x, &problem.mesh).unwrap());
    assert_eq!(Store::read(&store_path).unwrap().entries[&r.key], r);
    // the seed (here: the store, moved) lower than the writable store's entry wins
    let seed = dir.join("seed.json");
    std::fs::rename(&store_path, &seed).unwrap();
    std::fs::rename(dir.join("refs"), dir.join("seed")).unwrap();
    let mut book = Book::open(&stores).unwrap();
    let mut higher = r.clone();
    (higher.e_star, higher.map_checksum) = (problem.e0, map_checksum(&problem.x0));
    assert!(book.add(higher, &problem.x0, &problem.mesh).unwrap(), "the store is empty now");
    let both = crate::plan::paths::Stores { seed: Some(seed.clone()), ..stores };
    let book = Book::open(&both).unwrap();
    let (found, _, own) = lookup(&book, &r.key, &problem, &|_| {}).unwrap();
    assert_eq!((found.e_star, own), (r.e_star, false));
    assert_eq!(groups[0].e_star, Some(r.e_star));
    assert_eq!(Store::read(&seed).unwrap().entries[&r.key], r, "the seed is never written");
}

/// A map of a batch's run below `E*` lowers the reference: verified, polished, certified,
/// added to the store with the run as its provenance; a map whose energy is not the one its
/// run reported is not taken.
#[test]
fn a_run_below_the_reference_lowers_it_once_verified() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let plan = plan(dir, "m", "\"sd\"", "");
    let runs: Vec<&PlannedRun> = plan.runs.iter().collect();
    let (mut groups, _) = prepared_plan(&plan);
    let problem = Problem::of(&plan, &plan.runs[0]).unwrap();
    let stored = Store::read(&dir.join("refs.json")).unwrap();
    let x = store::verify(stored.entries.values().next().unwrap(), &stored.maps(), &problem).unwrap();
    let e_star = groups[0].e_star.unwrap();
    // pretend the store held a worse minimum: the start's energy
    groups[0].e_star = Some(problem.e0);
    let source = BatchSource {
        config: "t".into(),
        code: "test".into(),
        folder: "f".into(),
        run: plan.runs[0].stem.clone(),
        unix_time: 1,
    };
    let candidate = |energy: f64| improve::Candidate {
        stem: plan.runs[0].stem.clone(),
        dataset: "m".into(),
        energy_name: "sd".into(),
        x: x.clone(),
        energy,
        steps: Vec::new(),
    };
    let notices = RefCell::new(Vec::new());
    let notice = |l: &str| notices.borrow_mut().push(l.to_string());
    // the run says 1.0 but its map is at E*: not taken
    let mut lied = groups.clone();
    improve::improve(&plan, &runs, &mut lied, vec![(candidate(1.0), source.clone())], &notice, &AtomicBool::new(false))
        .unwrap();
    assert_eq!(lied[0].e_star, Some(problem.e0));
    assert!(notices.borrow().iter().any(|n| n.contains("not taken")), "{:?}", notices.borrow());
    improve::improve(&plan, &runs, &mut groups, vec![(candidate(e_star), source)], &notice, &AtomicBool::new(false))
        .unwrap();
    assert_eq!((groups[0].e_star, groups[0].origin), (Some(e_star), Origin::Improved));
    assert!(groups[0].certified && groups[0].note.as_deref().unwrap_or("").contains("lowered from"));
    // the store's entry names the batch's run (the store already had it as low: kept)
    let r = Store::read(&dir.join("refs.json")).unwrap().entries.into_values().next().unwrap();
    assert_eq!(r.e_star, e_star);
}

/// exp-SD starts from the SD minimum of the same problem: the batch looks the SD reference up
/// (or computes and stores it, with a notice), every exp-SD run and the exp-SD reference start
/// there, the Tutte start's keys stay, and `start = "tutte"` keeps the papers' start.
#[test]
fn exp_sd_starts_from_the_sd_reference_of_the_same_problem() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), fan(0.3)).unwrap();
    let chained = plan(dir, "m", "\"exp-sd\"", "");
    assert_eq!(missing(&chained).unwrap(), [("m".to_string(), "exp-sd".to_string())]);
    let (groups, notices) = prepared_plan(&chained);
    assert!(notices[0].contains("computing (the sd-minimum start of m)"), "{notices:?}");
    // both references stored: the SD one the start is, and exp-SD's from there
    let store = Store::read(&dir.join("refs.json")).unwrap();
    let sd = store.entries.values().find(|r| r.energy == "sd").expect("the SD reference is stored");
    let exp = store.entries.values().find(|r| r.energy == "exp-sd").unwrap();
    assert_eq!((exp.start.as_str(), sd.start.as_str()), ("sd-minimum", "tutte-scaled"));
    assert_eq!(groups[0].start_energy, Some(exp.start_energy));
    // E0 is exp-SD at the SD reference's map, and every run starts there
    let problem = Problem::of(&chained, &chained.runs[0]).unwrap();
    let sd_run = crate::plan::starts::sd_problem(&chained, &chained.runs[0]).unwrap();
    let sd_problem = Problem::of(&chained, &sd_run).unwrap();
    let book = Book::open(chained.references.as_ref().unwrap()).unwrap();
    let (_, x_sd, _) = lookup(&book, &sd.key, &sd_problem, &|_| {}).unwrap();
    assert_eq!(problem.x0, x_sd);
    assert_eq!(problem.start, solvers::solver::StartMap::SdMinimum);
    assert_eq!(problem.e0.to_bits(), problem.energy_of(&x_sd).to_bits());
    assert!(exp.e_star <= problem.e0 && exp.certificate.certified, "{exp:?}");
    assert!(missing(&chained).unwrap().is_empty());
    // a fresh plan finds both in the store: nothing computed again
    let (again, notices) = prepared(dir, "m", "\"exp-sd\"", "");
    assert_eq!((again[0].origin, again[0].e_star), (Origin::Store, Some(exp.e_star)));
    assert!(notices.is_empty(), "{notices:?}");
    // the Tutte start is another problem, with the key the Tutte start always had
    let tutte = plan(dir, "m", "\"exp-sd\"", "[energy.exp-sd]\nstart = \"tutte\"\n");
    let tutte_key = key(&tutte, &tutte.runs[0]).unwrap();
    assert_ne!(Some(&tutte_key), groups[0].key.as_ref());
    let crate::plan::RunSettings::Param { settings, .. } = &tutte.runs[0].settings else { panic!() };
    let text = tutte.runs[0].settings.problem_key_text();
    assert!(!text.contains("start") && settings.start == solvers::tasks::param::ParamStart::Tutte, "{text}");
}
