use super::evaluate::run_value;
use super::*;
use crate::plan::Task;
use crate::run_folder::summary::ToTarget;
use crate::run_folder::Status;

/// A finished `param` run on `d` (of `v` vertices) with `it` iterations, solved at the target
/// after `to` iterations when given.
fn run(d: &str, v: usize, energy: &str, solver: &str, it: usize, to: Option<usize>) -> SummaryRow {
    SummaryRow {
        dataset: d.into(),
        task: Task::Param,
        energy: energy.into(),
        solver: solver.into(),
        vertices: Some(v),
        iterations: Some(it),
        status: Status::Ok,
        time_s: Some(it as f64 * 0.01),
        ms_per_vertex: Some(it as f64 * 10.0 / v as f64),
        final_energy: Some(2.0 + 1e-3 / it as f64),
        to_targets: vec![ToTarget { tau: 1e-6, iters: to, time_s: to.map(|t| t as f64 * 0.01) }],
        ..SummaryRow::default()
    }
}

fn claim(text: &str) -> Claim {
    let file = format!("paper = \"p\"\ntitle = \"P\"\n[[claim]]\nid = \"c\"\nsource = \"Table 1\"\nsays = \"x\"\nconfigs = [\"papers\"]\n{text}");
    Paper::parse("test.toml", &file).unwrap().claims.remove(0)
}

const FEWEST: &str = "energy = \"sd\"\nmetric = \"iterations\"\ncheck = \"fewest\"\nsolver = \"kp-newton\"\nothers = [\"cm\", \"akvf\"]\n";

#[test]
fn the_committed_claims_parse_and_are_at_least_twelve_with_unique_ids() {
    let papers = built_in().unwrap();
    let ids: Vec<String> =
        papers.iter().flat_map(|p| p.claims.iter().map(move |c| format!("{}/{}", p.paper, c.id))).collect();
    assert!(ids.len() >= 12, "{ids:?}");
    let mut unique = ids.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(unique.len(), ids.len());
    assert_eq!(papers.len(), 3);
}

#[test]
fn fewest_holds_by_the_mean_over_the_meshes_all_solvers_ran_and_turns_with_ten_times_the_iterations() {
    let c = claim(FEWEST);
    let mut rows = vec![
        run("a", 100, "sd", "kp-newton", 10, Some(8)),
        run("a", 100, "sd", "cm", 12, Some(11)),
        run("a", 100, "sd", "akvf", 90, None),
        run("b", 200, "sd", "kp-newton", 20, Some(15)),
        run("b", 200, "sd", "cm", 20, Some(16)),
        run("b", 200, "sd", "akvf", 300, Some(250)),
        // akvf failed on c: c is left out for every solver
        run("c", 300, "sd", "kp-newton", 500, Some(400)),
        run("c", 300, "sd", "cm", 5, Some(5)),
        SummaryRow { status: Status::Failed, ..run("c", 300, "sd", "akvf", 0, None) },
        // another energy does not count
        run("a", 100, "nh", "kp-newton", 900, Some(900)),
    ];
    let j = evaluate::judge(&c, Rule::Paper, &rows);
    assert_eq!(j.outcome, ClaimOutcome::Held, "{j:?}");
    assert_eq!(j.datasets, ["a", "b"]);
    assert_eq!(j.ours["kp-newton"], 15.0);
    assert_eq!(j.ours["cm"], 16.0);
    assert!(j.why.contains("left out: c (akvf failed)"), "{}", j.why);
    assert_eq!(j.runs.len(), 6);
    // by the verdict: akvf never reached the target on a, so its mean is infinite, and kp
    // still has the fewest
    let v = evaluate::judge(&c, Rule::Verdict, &rows);
    assert_eq!(v.outcome, ClaimOutcome::Held, "{v:?}");
    assert_eq!(v.ours["kp-newton"], 11.5);
    assert_eq!((v.ours["akvf"], v.unreached["akvf"]), (250.0, 1), "its mean where it reached it, and where not");
    assert!(v.why.contains("akvf 250 (never at the target on 1)"), "{}", v.why);
    // ten times kp-newton's iterations: not held by either rule
    for r in rows.iter_mut().filter(|r| r.solver == "kp-newton") {
        r.iterations = r.iterations.map(|i| i * 10);
        r.to_targets[0].iters = r.to_targets[0].iters.map(|i| i * 10);
    }
    assert_eq!(evaluate::judge(&c, Rule::Paper, &rows).outcome, ClaimOutcome::NotHeld);
    assert_eq!(evaluate::judge(&c, Rule::Verdict, &rows).outcome, ClaimOutcome::NotHeld);
}

#[test]
fn by_the_verdict_fewer_meshes_never_at_the_target_first_then_the_mean_where_both_reached_it() {
    let c = claim(
        "energy = \"sd\"\nmetric = \"iterations\"\ncheck = \"less\"\nsolver = \"kp-newton\"\nothers = [\"cm\"]\n",
    );
    // both never reached it on a; on b kp took 30 and cm 20: cm is cheaper
    let mut rows = vec![
        run("a", 100, "sd", "kp-newton", 10, None),
        run("a", 100, "sd", "cm", 12, None),
        run("b", 200, "sd", "kp-newton", 40, Some(30)),
        run("b", 200, "sd", "cm", 40, Some(20)),
    ];
    assert_eq!(evaluate::judge(&c, Rule::Verdict, &rows).outcome, ClaimOutcome::NotHeld);
    // kp reaching it on a as well beats any mean
    rows[0].to_targets[0] = ToTarget { tau: 1e-6, iters: Some(900), time_s: Some(9.0) };
    let v = evaluate::judge(&c, Rule::Verdict, &rows);
    assert_eq!(v.outcome, ClaimOutcome::Held, "{v:?}");
    assert_eq!((v.unreached["kp-newton"], v.unreached["cm"]), (0, 1));
}

#[test]
fn two_solvers_that_never_reach_the_target_cannot_be_ordered() {
    let c = claim(FEWEST);
    let rows = vec![
        run("a", 100, "sd", "kp-newton", 10, None),
        run("a", 100, "sd", "cm", 12, None),
        run("a", 100, "sd", "akvf", 90, Some(80)),
    ];
    let v = evaluate::judge(&c, Rule::Verdict, &rows);
    assert_eq!(v.outcome, ClaimOutcome::NotMeasurable, "{v:?}");
    // a run that was not judged has no number by the verdict
    let unjudged: Vec<SummaryRow> = rows.iter().map(|r| SummaryRow { to_targets: vec![], ..r.clone() }).collect();
    let v = evaluate::judge(&c, Rule::Verdict, &unjudged);
    assert_eq!(v.outcome, ClaimOutcome::NotMeasurable);
    assert!(v.why.starts_with("no mesh of sd"), "{}", v.why);
}

#[test]
fn each_vocabulary_check_decides_as_documented() {
    let rows = vec![
        run("a", 100, "sd", "kp-newton", 10, Some(10)),
        run("a", 100, "sd", "cm", 10, Some(10)),
        run("a", 100, "sd", "fp-newton-4x4", 11, Some(11)),
        run("b", 1000, "sd", "kp-newton", 20, Some(20)),
        run("b", 1000, "sd", "cm", 20, Some(20)),
        run("b", 1000, "sd", "fp-newton-4x4", 30, Some(30)),
        run("c", 10000, "sd", "kp-newton", 30, Some(30)),
        run("c", 10000, "sd", "cm", 31, Some(31)),
        run("c", 10000, "sd", "fp-newton-4x4", 5, Some(5)),
    ];
    let decide = |text: &str| evaluate::judge(&claim(text), Rule::Paper, &rows);
    let base = "energy = \"sd\"\nmetric = \"iterations\"\nsolver = \"kp-newton\"\n";
    let with = |rest: &str| format!("{base}{rest}");
    // means: kp 20, cm 20.33, fp 15.33
    assert_eq!(decide(&with("check = \"less\"\nothers = [\"cm\"]")).outcome, ClaimOutcome::Held);
    assert_eq!(decide(&with("check = \"less\"\nothers = [\"fp-newton-4x4\"]")).outcome, ClaimOutcome::NotHeld);
    assert_eq!(decide(&with("check = \"most\"\nothers = [\"fp-newton-4x4\"]")).outcome, ClaimOutcome::Held);
    assert_eq!(decide(&with("check = \"within\"\ntolerance = 0.02\nothers = [\"cm\"]")).outcome, ClaimOutcome::Held);
    assert_eq!(decide(&with("check = \"within\"\ntolerance = 0.01\nothers = [\"cm\"]")).outcome, ClaimOutcome::NotHeld);
    assert_eq!(decide(&with("check = \"order\"\nothers = [\"cm\"]")).outcome, ClaimOutcome::Held);
    assert_eq!(decide(&with("check = \"order\"\nothers = [\"fp-newton-4x4\", \"cm\"]")).outcome, ClaimOutcome::NotHeld);
    // per mesh: kp below fp on a and b only; equal to cm on a and b only
    let each = decide(&with("check = \"each_less\"\nothers = [\"fp-newton-4x4\"]"));
    assert_eq!(each.outcome, ClaimOutcome::NotHeld);
    assert!(each.why.contains("on 2 of 3 meshes") && each.why.contains("not on c"), "{}", each.why);
    assert_eq!(
        decide(&with("check = \"each_less\"\nat_least = 0.6\nothers = [\"fp-newton-4x4\"]")).outcome,
        ClaimOutcome::Held
    );
    assert_eq!(decide(&with("check = \"each_equal\"\nothers = [\"cm\"]")).outcome, ClaimOutcome::NotHeld);
    assert_eq!(decide(&with("check = \"each_at_most\"\nvalue = 30")).outcome, ClaimOutcome::Held);
    assert_eq!(decide(&with("check = \"each_at_most\"\nvalue = 29")).outcome, ClaimOutcome::NotHeld);
    assert_eq!(
        decide(&with("check = \"each_at_most\"\nvalue = 25\nmin_vertices = 5000")).outcome,
        ClaimOutcome::NotHeld,
        "c alone counts"
    );
    assert_eq!(decide(&with("check = \"each_at_most\"\nvalue = 25\nmin_vertices = 500")).datasets, ["b", "c"]);
    // fp falls with size from b on, but rises from a to b: 2 pairs fall, 1 rises
    let falls = "energy = \"sd\"\nmetric = \"iterations\"\nsolver = \"fp-newton-4x4\"\ncheck = \"falls_with_size\"";
    assert_eq!(decide(falls).outcome, ClaimOutcome::Held, "{:?}", decide(falls));
    assert_eq!(decide(&with("check = \"falls_with_size\"")).outcome, ClaimOutcome::NotHeld);
    // a published value on one mesh: kp's final energy on b is 2.00005
    let value =
        "energy = \"sd\"\nmetric = \"final_energy\"\nsolver = \"kp-newton\"\ncheck = \"value\"\ndataset = \"b\"\n";
    assert_eq!(
        decide(&format!("{value}tolerance = 1e-4\npublished = {{ kp-newton = 2.0001 }}")).outcome,
        ClaimOutcome::Held
    );
    assert_eq!(
        decide(&format!("{value}tolerance = 1e-6\npublished = {{ kp-newton = 2.0001 }}")).outcome,
        ClaimOutcome::NotHeld
    );
    let absent = "energy = \"sd\"\nmetric = \"final_energy\"\nsolver = \"kp-newton\"\ncheck = \"value\"\ndataset = \"hilbert\"\ntolerance = 1e-4\npublished = { kp-newton = 2.0 }";
    assert_eq!(decide(absent).outcome, ClaimOutcome::NotMeasurable);
}

#[test]
fn a_claims_file_with_a_missing_or_unknown_field_is_refused_naming_the_claim() {
    let bad = |text: &str| {
        let file = format!("paper = \"p\"\ntitle = \"P\"\n[[claim]]\nid = \"c1\"\nsource = \"T\"\nsays = \"x\"\nconfigs = [\"papers\"]\nenergy = \"sd\"\nmetric = \"iterations\"\n{text}");
        Paper::parse("p.toml", &file).unwrap_err().to_string()
    };
    assert!(bad("check = \"fewest\"\nsolver = \"kp-newton\"")
        .contains("p.toml: claim 'c1': check 'fewest' compares with `others`"));
    assert!(bad("check = \"fewest\"\nsolver = \"kp\"\nothers = [\"cm\"]").contains("'kp' is not a catalogue solver"));
    assert!(bad("check = \"within\"\nsolver = \"cm\"\nothers = [\"kp-newton\"]").contains("needs `tolerance`"));
    assert!(bad("check = \"value\"\nsolver = \"cm\"\ntolerance = 1e-4\ndataset = \"hilbert\"")
        .contains("needs `published.cm`"));
    assert!(bad("check = \"each_at_most\"\nsolver = \"cm\"\nothers = [\"kp-newton\"]\nvalue = 1")
        .contains("would be ignored"));
    assert!(bad("check = \"fewest\"\nsolver = \"cm\"\nothers = [\"kp-newton\"]\nat_least = 0.5")
        .contains("for check 'each_less' only"));
    assert!(bad("check = \"fastest\"\nsolver = \"cm\"").contains("p.toml"), "an unknown check");
    assert!(bad("check = \"less\"\nsolver = \"cm\"\nothers = [\"kp-newton\"]\ncolour = 1").contains("unknown field"));
}

#[test]
fn a_claim_no_folder_answers_names_the_configs_that_would() {
    let papers = built_in().unwrap();
    let rows = vec![run("a", 100, "sd", "kp-newton", 10, Some(8))];
    let folders = [Folder { config: "papers".into(), dir: "/tmp/x".into(), rows }];
    let all = evaluate(&papers, &folders);
    let t6 = all.iter().find(|c| c.id == "golla2018/t6-akvf-most-iterations-deform").unwrap();
    assert_eq!(t6.rules.len(), 2);
    assert!(t6.rules.iter().all(|j| j.outcome == ClaimOutcome::NotMeasurable && j.why.contains("papers_deform")));
    let energy = all.iter().find(|c| c.id == "shtengel2017/t1-hilbert-cm-energy").unwrap();
    assert_eq!(energy.rules.len(), 1, "a final energy has one rule");
    assert_eq!(energy.folder.as_deref(), Some(Path::new("/tmp/x")));
    let [held, not, unmeasurable] = counts(&all);
    assert_eq!(held + not + unmeasurable, all.iter().map(|c| c.rules.len()).sum::<usize>());
}

#[test]
fn numbers_show_six_significant_digits_without_trailing_zeros() {
    assert_eq!(evaluate::fmt(2.000012), "2.00001");
    assert_eq!(evaluate::fmt(67.3), "67.3");
    assert_eq!(evaluate::fmt(12.0), "12");
    assert_eq!(evaluate::fmt(f64::INFINITY), "never at the target");
}

/// By the paper's rule a run that went on to its target reads at its rule's first event (the
/// run that rule ends has those rows), the earlier of two rules; a run no rule held in reads
/// at its own end. By the verdict it reads at the target.
#[test]
fn the_paper_s_rule_reads_a_run_at_its_rule_s_event() {
    let mut r = run("a", 100, "sd", "kp-newton", 40, Some(40));
    (r.rule_grad_tol_iters, r.rule_grad_tol_time_s, r.rule_grad_tol_energy) = (Some(12), Some(0.1), Some(2.5));
    (r.rule_energy_decrease_iters, r.rule_energy_decrease_time_s, r.rule_energy_decrease_energy) =
        (Some(30), Some(0.3), Some(2.1));
    assert_eq!(run_value(Quantity::Iterations, Rule::Paper, &r), Some(12.0));
    assert_eq!(run_value(Quantity::TimeS, Rule::Paper, &r), Some(0.1));
    assert_eq!(run_value(Quantity::FinalEnergy, Rule::Paper, &r), Some(2.5));
    // 4 ms per vertex over the run's 0.4 s: a quarter of it to the event
    assert_eq!(run_value(Quantity::MsPerVertex, Rule::Paper, &r), Some(1.0));
    assert_eq!(run_value(Quantity::Iterations, Rule::Verdict, &r), Some(40.0));
    r.rule_grad_tol_iters = None;
    assert_eq!(run_value(Quantity::Iterations, Rule::Paper, &r), Some(30.0));
    let own = run("a", 100, "sd", "cm", 25, None);
    assert_eq!(run_value(Quantity::Iterations, Rule::Paper, &own), Some(25.0));
    assert_eq!(run_value(Quantity::Iterations, Rule::Verdict, &own), Some(f64::INFINITY));
}
