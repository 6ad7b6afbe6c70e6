//! External solvers in a batch: the template adapter runs under verification next to ours and
//! resumes and repeats like them; a solver that lies about its energy, hangs past the timeout,
//! exits non-zero, writes garbage or a map of the wrong size fails its run alone; one that
//! cannot start is skipped with the reason; a stationary end it claims is checked on its records;
//! libigl's SLIM runs where `libigl` is installed.
//!
//! The Python peers need numpy (and `igl-slim` libigl): without them these tests are skipped
//! with a notice, unless `MAPBENCH_REQUIRE_PEERS` is set (`.ci/run` sets it), which turns a
//! missing package into a failure.

use crate::common;

use common::*;
use std::path::Path;

const INSTALL: &str = "python3 -m pip install -r peers/requirements.txt";

/// Whether `python3` imports `module`.
fn python_imports(module: &str) -> bool {
    std::process::Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether the peers' `python3` has numpy; when not, a one-line notice (or, with
/// `MAPBENCH_REQUIRE_PEERS` set, a failure) and the test skips.
fn peers_run() -> bool {
    if python_imports("numpy") {
        return true;
    }
    assert!(
        std::env::var_os("MAPBENCH_REQUIRE_PEERS").is_none(),
        "MAPBENCH_REQUIRE_PEERS: python3 has no numpy ({INSTALL})"
    );
    notice(&format!("skipped: python3 has no numpy for the Python peers ({INSTALL})"));
    false
}

/// A line on the terminal's standard error, past the test harness's capture (which keeps a
/// passing test's `eprintln!` to itself).
fn notice(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// A peer in Python on `peers/mapbench_peer.py`: `body` runs with `p` the problem, `uv` its
/// start map and `e` its energy.
fn peer(dir: &Path, name: &str, body: &str) -> String {
    let peers = repo_root().join("peers");
    let script = format!(
        "import sys, time\nsys.path.insert(0, {peers:?})\nimport numpy as np\nfrom mapbench_peer import Problem\n\
         p = Problem(sys.argv[-1])\nuv = p.start\ne = p.sd(uv)\n{body}\n",
        peers = peers.display().to_string()
    );
    let path = dir.join(format!("{name}.py"));
    std::fs::write(&path, script).unwrap();
    path.display().to_string()
}

/// `[external.<name>]` running `command`; it may read `peers/` (where its scripts import
/// `mapbench_peer` from), as the sandbox lets it read only what its declaration grants.
fn external(name: &str, command: &[&str], extra: &str) -> String {
    let command: Vec<String> = command.iter().map(|c| format!("{c:?}")).collect();
    let peers = repo_root().join("peers").display().to_string();
    format!(
        "[external.{name}]\ncommand = [{}]\ntasks = [\"param\"]\nenergies = [\"sd\"]\nread = [{peers:?}]\n{extra}",
        command.join(", ")
    )
}

fn column<'a>(h: &[String], rows: &'a [Vec<String>], solver: &str, name: &str) -> &'a str {
    let col = |n: &str| h.iter().position(|x| x == n).unwrap_or_else(|| panic!("no column {n}"));
    &rows.iter().find(|r| r[col("solver")] == solver).unwrap_or_else(|| panic!("no run of {solver}"))[col(name)]
}

#[test]
fn external_solvers_are_verified_and_each_failure_stays_in_its_run() {
    if !peers_run() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let gd = repo_root().join("peers/example_gd.py").display().to_string();
    let liar = peer(d, "liar", "p.record(0, 2 * e, uv)\np.finish('max_iters')");
    let crash = peer(d, "crash", "p.record(0, e, uv)\nprint('boom', file=sys.stderr)\nsys.exit(3)");
    let short = peer(d, "short", "p.record(0, e, uv[:-1])\np.finish('max_iters')");
    let garbage =
        peer(d, "garbage", "open(p.folder + '/iterations.jsonl', 'w').write('garbage\\n')\np.finish('max_iters')");
    // starts a grandchild, writes the start, then hangs: the timeout ends the whole group
    let hang = peer(
        d,
        "hang",
        "import subprocess\nchild = subprocess.Popen(['sleep', '600'])\nprint(child.pid, flush=True)\n\
         p.record(0, e, uv)\ntime.sleep(600)",
    );
    let mute = peer(d, "mute", "time.sleep(600)");
    let mut config = String::from(
        "name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\", \"sarap\"]\ntimeout = \"10s\"\nmaps = \"all\"\n\
         solvers = [\"kp-newton\", \"gd\", \"liar\", \"crash\", \"short\", \"garbage\", \"hang\", \"mute\", \"absent\", \
         \"nopkg\"]\n[stop]\nmax_iters = 12\n",
    );
    for (name, script) in
        [("liar", &liar), ("crash", &crash), ("short", &short), ("garbage", &garbage), ("hang", &hang), ("mute", &mute)]
    {
        config += &external(name, &["python3", script], "");
    }
    config += &external(
        "gd",
        &["python3", &gd],
        "version = [\"python3\", \"-c\", \"print('gd 1.0')\"]\nsnapshot_every = 3\n",
    );
    config += &external("absent", &["no-such-solver-xyz"], "");
    config +=
        &external("nopkg", &["python3", "x.py"], "version = [\"python3\", \"-c\", \"import no_such_package_xyz\"]\n");
    let cfg = write_config(d, &config);
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--jobs", "2", "--no-history"], d);
    // runs failed (exit 1), the batch finished
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    // ok: kp-newton on sd; kp-newton's SARAP run goes on past its energy-decrease rule, gd
    // stops at its cap, hang at its timeout
    assert!(text(&o).contains("20 runs: 1 ok, 3 not converged, 5 failed, 11 skipped"), "{}", text(&o));
    let (h, rows) = read_csv(&d.join("out/summary.csv"));
    let sd: Vec<Vec<String>> = rows.iter().filter(|r| r[2] == "sd").cloned().collect();
    let get = |solver: &str, name: &str| column(&h, &sd, solver, name).to_string();

    // ours and the template: the same start, every third map and the last verified
    assert_eq!(get("kp-newton", "status"), "ok");
    assert_eq!(get("gd", "start"), get("kp-newton", "start"));
    assert_eq!(get("gd", "init_energy"), get("kp-newton", "init_energy"));
    assert_eq!((get("gd", "iterations").as_str(), get("gd", "stop_reason").as_str()), ("12", "max_iters"));
    assert_eq!(get("gd", "verified_snapshots"), "5", "iterations 0, 3, 6, 9, 12");
    assert_eq!(get("gd", "flips"), "0");
    assert!(get("gd", "peak_rss_mb").parse::<f64>().unwrap() > 1.0);
    assert!(get("gd", "verdict") == "unfinished", "{}", get("gd", "verdict"));
    assert_eq!(get("kp-newton", "verified_snapshots"), "");
    // its final map scores as the run says
    let s = mapbench(&["evaluate", "--json", "out/meshes/bumpy_1k.obj.gz", "out/uv/bumpy_1k__sd__gd.uv.gz"], d);
    let s: serde_json::Value = serde_json::from_slice(&s.stdout).unwrap();
    assert_eq!(s["energy_value"].as_f64().unwrap().to_string(), get("gd", "final_energy"));
    // its rows: the verified column, its own extra column, times on its clock
    let (ih, irows) = read_csv(&d.join("out/runs/bumpy_1k__sd__gd.csv"));
    let icol = |n: &str| ih.iter().position(|x| x == n).unwrap_or_else(|| panic!("no column {n} in {ih:?}"));
    let verified: Vec<&str> = irows.iter().map(|r| r[icol("verified")].as_str()).collect();
    assert_eq!(verified, ["1.0", "0.0", "0.0", "1.0", "0.0", "0.0", "1.0", "0.0", "0.0", "1.0", "0.0", "0.0", "1.0"]);
    // its own gradient norm (an extra) against ours at the verified rows
    for r in irows.iter().filter(|r| r[icol("verified")] == "1.0") {
        let (own, ours): (f64, f64) =
            (r[icol("own_grad_norm")].parse().unwrap(), r[icol("grad_norm")].parse().unwrap());
        assert!((own - ours).abs() <= 1e-9 * ours, "{own} vs {ours}");
    }
    assert!(irows.iter().skip(1).all(|r| r[icol("t_iter_s")].parse::<f64>().unwrap() >= 0.0));
    // the pair outside its declared energies is skipped
    let sarap = |solver: &str, name: &str| {
        column(&h, &rows.iter().filter(|r| r[2] == "sarap").cloned().collect::<Vec<_>>(), solver, name).to_string()
    };
    assert_eq!(sarap("gd", "status"), "skipped");
    assert_eq!(sarap("gd", "error"), "gd is an external solver of sd only");

    // each failure in its run, named
    let failed = |solver: &str, says: &str| {
        assert_eq!(get(solver, "status"), "failed", "{solver}: {}", get(solver, "error"));
        assert!(get(solver, "error").contains(says), "{solver}: {}", get(solver, "error"));
    };
    failed("liar", "iteration 0: the solver reported energy");
    failed("liar", "(a factor of 2: another convention of the energy?)");
    failed("crash", "crash exited with code 3 (its last error line: boom)");
    failed("short", "map vertices, but the mesh has");
    failed("garbage", "iterations.jsonl line 1: not a record");
    failed("mute", "mute passed its timeout before it wrote the start map");
    // a hang after the start: a timeout at its last map, like ours at their deadline
    assert_eq!((get("hang", "stop_reason").as_str(), get("hang", "iterations").as_str()), ("timeout", "0"));
    assert!(get("hang", "time_s").parse::<f64>().unwrap() < 30.0);
    let pid = std::fs::read_to_string(d.join("out/external/bumpy_1k__sd__hang.stdout.txt")).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let state = std::fs::read_to_string(format!("/proc/{}/stat", pid.trim())).unwrap_or_default();
    assert!(state.is_empty() || state.contains(") Z"), "the hung peer's grandchild outlived it: {state}");
    // what cannot start is skipped with the reason
    assert_eq!(get("absent", "status"), "skipped");
    assert!(get("absent", "error").contains("no program 'no-such-solver-xyz' on PATH"), "{}", get("absent", "error"));
    assert_eq!(get("nopkg", "status"), "skipped");
    assert!(get("nopkg", "error").contains("No module named 'no_such_package_xyz'"), "{}", get("nopkg", "error"));
    // the output kept, the problem folders gone
    assert_eq!(std::fs::read_to_string(d.join("out/external/bumpy_1k__sd__crash.stderr.txt")).unwrap(), "boom\n");
    assert!(!d.join("out/external/bumpy_1k__sd__gd").exists());
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/meta.json")).unwrap()).unwrap();
    let gd_probe = meta["external"].as_array().unwrap().iter().find(|p| p["name"] == "gd").unwrap();
    assert_eq!(gd_probe["version"], "gd 1.0");
    let index = std::fs::read_to_string(d.join("out/index.html")).unwrap();
    assert!(index.contains("<h2 id=\"external\">External solvers</h2>") && index.contains("gd 1.0"));

    // --resume takes the finished external runs back; --repeat reproduces them bit for bit
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--resume", "--no-history", "--jobs", "2"], d);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("bumpy_1k sd gd: resumed, ran (max_iters), 12 iterations"), "{}", text(&o));
    // a skip for want of a program is not kept: it is asked again
    assert!(text(&o).contains("bumpy_1k sd absent: skipped"), "{}", text(&o));
    let o = mapbench(
        &[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            "again",
            "--repeat",
            "2",
            "--no-history",
            "--only",
            "bumpy_1k__sd__gd",
        ],
        d,
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h2, rows2) = read_csv(&d.join("again/summary.csv"));
    // out of budget: its time ranks nothing, so it keeps its one sample (the repeats of a run
    // that reached its target: the libigl test)
    assert_eq!(column(&h2, &rows2, "gd", "repeats"), "1");
    assert_eq!(column(&h2, &rows2, "gd", "final_energy"), get("gd", "final_energy"));
}

#[test]
fn libigl_slim_runs_verified_where_libigl_is_installed_and_is_skipped_where_not() {
    // Without libigl the test checks the skip: the batch goes on, the runs say why.
    let has_igl = python_imports("igl");
    assert!(
        has_igl || std::env::var_os("MAPBENCH_REQUIRE_PEERS").is_none(),
        "MAPBENCH_REQUIRE_PEERS: python3 has no libigl ({INSTALL})"
    );
    let tmp = tempfile::tempdir().unwrap();
    let cfg = repo_root().join("configs/peers.toml");
    let o = mapbench(
        &["run", cfg.to_str().unwrap(), "--out", "out", "--no-history", "--only", "bumpy_1k__*", "--jobs", "1"],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&tmp.path().join("out/summary.csv"));
    let get = |solver: &str, name: &str| column(&h, &rows, solver, name).to_string();
    if has_igl {
        assert_eq!(get("igl-slim", "status"), "ok", "{}", get("igl-slim", "error"));
        let iterations: usize = get("igl-slim", "iterations").parse().unwrap();
        assert_eq!(get("igl-slim", "verified_snapshots"), (iterations + 1).to_string());
        assert_eq!(get("igl-slim", "init_energy"), get("kp-newton", "init_energy"));
        // both went to the target the problem folder named, and the harness agrees
        assert_eq!(
            (get("igl-slim", "stop_reason").as_str(), get("igl-slim", "verdict").as_str()),
            ("target", "solved")
        );
        assert_eq!(get("kp-newton", "verdict"), "solved");
        let (ours, theirs): (f64, f64) =
            (get("kp-newton", "final_energy").parse().unwrap(), get("igl-slim", "final_energy").parse().unwrap());
        let span: f64 = get("kp-newton", "gap_scale").parse().unwrap();
        assert!((ours - theirs).abs() <= 1e-6 * span, "kp-newton {ours} vs igl-slim {theirs}");
        // a run that reached its target is repeated, bit for bit
        let o = mapbench(
            &[
                "run",
                cfg.to_str().unwrap(),
                "--out",
                "again",
                "--no-history",
                "--only",
                "bumpy_1k__sd__igl-slim",
                "--repeat",
                "2",
            ],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let (h2, rows2) = read_csv(&tmp.path().join("again/summary.csv"));
        assert_eq!(column(&h2, &rows2, "igl-slim", "repeats"), "2");
        assert_eq!(column(&h2, &rows2, "igl-slim", "repeats_differ"), "");
        assert_eq!(column(&h2, &rows2, "igl-slim", "final_energy"), get("igl-slim", "final_energy"));
    } else {
        notice(&format!("note: python3 has no libigl: checked that igl-slim's runs are skipped ({INSTALL})"));
        assert_eq!(get("igl-slim", "status"), "skipped");
        assert!(get("igl-slim", "error").contains("No module named 'igl'"), "{}", get("igl-slim", "error"));
    }
}

/// A solver that says it ended stationary is read as ours did; one whose records or final map
/// do not bear it out fails its run.
#[test]
fn an_external_stationary_end_is_read_as_ours_and_one_its_records_do_not_bear_out_fails() {
    if !peers_run() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // the start map again and again: the stall the problem's window of 3 asks for
    let flat = peer(
        d,
        "flat",
        "assert p.stop['stall_window'] == 3 and p.stop['stall_rtol'] == 1e-12, p.stop\n\
         for k in range(4):\n    p.record(k, e, uv, final=k == 3)\np.finish('no_decrease')",
    );
    let early = peer(d, "early", "p.record(0, e, uv)\np.record(1, e, uv, final=True)\np.finish('no_decrease')");
    let floor = peer(d, "floor", "p.record(0, e, uv, final=True)\np.finish('grad_floor')");
    let mut config = String::from(
        "name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"flat\", \"early\", \"floor\"]\n\
         [stop]\nstall_window = 3\n",
    );
    for (name, script) in [("flat", &flat), ("early", &early), ("floor", &floor)] {
        config += &external(name, &["python3", script], "");
    }
    let cfg = write_config(d, &config);
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--no-history"], d);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let (h, rows) = read_csv(&d.join("out/summary.csv"));
    let get = |solver: &str, name: &str| column(&h, &rows, solver, name).to_string();
    // stationary at the start, far above the minimum: a polish goes on down, so a stall
    assert_eq!((get("flat", "stop_reason").as_str(), get("flat", "verdict").as_str()), ("no_decrease", "stalled"));
    assert_eq!(get("flat", "iterations"), "3");
    assert_eq!(get("early", "status"), "failed");
    assert!(
        get("early", "error").contains("says no_decrease after 1 iterations, fewer than the stall window of 3"),
        "{}",
        get("early", "error")
    );
    assert_eq!(get("floor", "status"), "failed");
    assert!(
        get("floor", "error").contains("says grad_floor, but the gradient norm of its final map (iteration 0) is"),
        "{}",
        get("floor", "error")
    );
}

/// `deform`: the problem folder carries the handles, the template's objective adds their
/// penalty, and every map it reports is verified against our energy with the penalty; its
/// start is ours (the rest pose, or the shape's own).
#[test]
fn an_external_deform_run_is_verified_with_the_handles_penalty() {
    if !peers_run() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let gd = repo_root().join("peers/example_gd.py").display().to_string();
    let mut config = String::from(
        "name = \"d\"\ntask = \"deform\"\ndatasets = [\"planar_bar_2k\", \"planar_bar_release_2k\"]\n\
         energies = [\"sd\", \"nh\"]\nsolvers = [\"kp-newton\", \"gd\"]\n[stop]\nmax_iters = 6\n",
    );
    config += &external("gd", &["python3", &gd], "keep_problem = true\n").replace("[\"param\"]", "[\"deform\"]");
    let cfg = write_config(tmp.path(), &config);
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&tmp.path().join("out/summary.csv"));
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    for dataset in ["planar_bar_2k", "planar_bar_release_2k"] {
        let of = |solver: &str, energy: &str| {
            rows.iter()
                .find(|r| r[col("dataset")] == dataset && r[col("solver")] == solver && r[col("energy")] == energy)
        };
        let (ours, theirs) = (of("kp-newton", "sd").unwrap(), of("gd", "sd").unwrap());
        assert_eq!(theirs[col("stop_reason")], "max_iters", "{}", theirs[col("error")]);
        assert_eq!(theirs[col("verified_snapshots")], "7");
        // the same start map (checked bit for bit by the harness); its energy summed in
        // another order than the solver's evaluation adds the penalty
        assert_eq!(theirs[col("start")], ours[col("start")]);
        let (e0, e): (f64, f64) =
            (theirs[col("init_energy")].parse().unwrap(), theirs[col("final_energy")].parse().unwrap());
        let our_e0: f64 = ours[col("init_energy")].parse().unwrap();
        assert!((e0 - our_e0).abs() <= 1e-13 * our_e0, "{dataset}: {e0} vs {our_e0}");
        assert!(e < e0, "{dataset}: {e} from {e0}");
        assert_eq!(of("gd", "nh").unwrap()[col("status")], "skipped");
    }
    // the problem folder kept: the handles in the normalized frame
    let spec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("out/external/planar_bar_2k__sd__gd/problem.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(spec["task"], "deform");
    assert_eq!(spec["handles"]["lambda"].as_f64(), Some(1e5));
    let n = spec["handles"]["vertices"].as_array().unwrap().len();
    assert!(n > 0 && spec["handles"]["targets"].as_array().unwrap().len() == n);
}

/// `--shard` and `merge` take external runs like any other: the merged folder has every run
/// once, the external ones verified, and the solver's probe in its `meta.json`.
#[test]
fn external_runs_shard_and_merge_like_ours() {
    if !peers_run() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let gd = repo_root().join("peers/example_gd.py").display().to_string();
    let mut config = String::from(
        "name = \"s\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"gd\"]\n\
         [stop]\nmax_iters = 5\n",
    );
    config += &external("gd", &["python3", &gd], "version = [\"python3\", \"-c\", \"print('gd 2')\"]\n");
    let cfg = write_config(tmp.path(), &config);
    for shard in ["1/2", "2/2"] {
        let out = format!("shard{}", &shard[..1]);
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--shard", shard, "--out", &out, "--no-history"], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let o = mapbench(&["merge", "shard1", "shard2", "--out", "merged", "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&tmp.path().join("merged/summary.csv"));
    assert_eq!(rows.len(), 4);
    for dataset in ["bumpy_1k", "cap_2k"] {
        let r = rows.iter().find(|r| r[0] == dataset && r[3] == "gd").unwrap();
        assert_eq!(column(&h, std::slice::from_ref(r), "gd", "verified_snapshots"), "6", "{dataset}");
    }
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("merged/meta.json")).unwrap()).unwrap();
    assert_eq!(meta["external"][0]["version"], "gd 2");
    assert_eq!(meta["external"].as_array().unwrap().len(), 1);
}

/// A hostile or faulty peer: `body` runs after the preamble of [`peer`], with `raw(**record)`
/// writing a line of `iterations.jsonl` as given and `put(k, map)` writing `maps/<k>.uv`.
fn hostile(dir: &Path, name: &str, body: &str) -> String {
    let helpers = "import json, os, subprocess\nfrom mapbench_peer import write_uv\n\
                   def raw(**d):\n    p._records.write(json.dumps(d) + '\\n')\n    p._records.flush()\n\
                   def put(k, m):\n    write_uv(os.path.join(p.folder, 'maps', f'{k}.uv'), m)\n\
                   def now():\n    return time.perf_counter() - p.clock0\n";
    peer(dir, name, &format!("{helpers}{body}"))
}

/// The probe's hostile and faulty peers, each in one batch beside ours: every one fails alone
/// with its reason (or is judged on what it did), none changes another run's files or leaves a
/// file or a process outside its problem folder, and the timeout holds while a process it left
/// keeps the output pipes open.
#[test]
fn hostile_peers_fail_alone_with_their_reason_and_leave_nothing_behind() {
    // The peers import mapbench_peer, which needs numpy.
    if !peers_run() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let marker = d.join("escaped.txt");
    // (name, body, extra config lines)
    let cases: Vec<(&str, String, &str)> = vec![
        // an energy at a row without its map (below SD's least value, 2)
        ("unmapped", "raw(iter=0, energy=e, time_s=0.0)\nput(0, uv)\nraw(iter=1, energy=0.5, time_s=now())\n\
                      raw(iter=2, energy=e, time_s=now())\nput(2, uv)\np.finish('converged')".into(), ""),
        ("record_s", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=now(), record_s=1e6)\nput(1, uv)\n\
                      p.finish('max_iters')".into(), ""),
        ("future", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=1e9)\nput(1, uv)\np.finish('max_iters')".into(), ""),
        ("past_max", "for k in range(7):\n    p.record(k, e, uv)\np.finish('max_iters')".into(), ""),
        ("nan_map", "p.record(0, e, uv)\nm = uv.copy()\nm[5, 0] = float('nan')\nraw(iter=1, energy=e, time_s=now())\n\
                     put(1, m)\np.finish('max_iters')".into(), ""),
        ("inf_map", "p.record(0, e, uv)\nm = uv.copy()\nm[7, 1] = float('inf')\nraw(iter=1, energy=e, time_s=now())\n\
                     put(1, m)\np.finish('max_iters')".into(), ""),
        ("mirror", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=now())\nput(1, uv * np.array([-1.0, 1.0]))\n\
                    p.finish('max_iters')".into(), ""),
        ("reversed", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=now())\nput(1, uv[::-1])\n\
                      p.finish('max_iters')".into(), ""),
        ("fifo", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=now())\n\
                  os.mkfifo(os.path.join(p.folder, 'maps', '1.uv'))\np.finish('max_iters')".into(), ""),
        ("devzero", "p.record(0, e, uv)\nraw(iter=1, energy=e, time_s=now())\n\
                     os.symlink('/dev/zero', os.path.join(p.folder, 'maps', '1.uv'))\np.finish('max_iters')".into(), ""),
        ("long_line", "raw(iter=0, energy=e, time_s=0.0, note='x' * 20_000_000)\nput(0, uv)\np.finish('max_iters')".into(), ""),
        ("wide", "raw(iter=0, energy=e, time_s=0.0, **{f'c{i}': 1 for i in range(40)})\nput(0, uv)\n\
                  p.finish('max_iters')".into(), ""),
        ("long_message", "p.record(0, e, uv)\np.finish('error', 'y' * 20_000_000)".into(), ""),
        ("crash_long", "p.record(0, e, uv)\nsys.exit('z' * 1_000_000)".into(), ""),
        ("no_module", "import no_such_module_xyz".into(), ""),
        ("processes", "ps = [subprocess.Popen(['sleep', '30']) for _ in range(12)]\np.record(0, e, uv)\ntime.sleep(30)".into(),
         "processes = 8\n"),
        ("big_file", "p.record(0, e, uv)\nopen(os.path.join(p.folder, 'big'), 'wb').write(b'0' * 3_000_000)\n\
                      p.finish('max_iters')".into(), "file_size_mb = 1\n"),
        // writes outside its folder (refused), then solves honestly; tells what it saw
        ("outside", format!(
            "for t in ['../../runs/bumpy_1k__sd__kp-newton.csv', '../../summary.csv', '../x.txt', {marker:?}]:\n\
             \x20   try:\n        open(t, 'a').write('HACKED')\n        print('wrote', t)\n\
             \x20   except OSError as err:\n        print('refused', t)\n\
             for v in ['HOME', 'TMPDIR', 'OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS', 'NUMEXPR_NUM_THREADS']:\n\
             \x20   print(v, os.environ.get(v))\n\
             open(os.path.join(os.environ['TMPDIR'], 'scratch'), 'w').write('mine')\n\
             p.record(0, e, uv)\np.finish('max_iters')",
            marker = marker.display().to_string()
        ), ""),
        // a daemon that leaves its session and a worker that outlives its parent
        ("escape", "q = subprocess.Popen(['setsid', 'sleep', '300'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)\n\
                    print('pid', q.pid, flush=True)\np.record(0, e, uv)\np.finish('max_iters')".into(), ""),
        // keeps the output pipes open from its own session, then hangs: the timeout holds
        ("pipes", "q = subprocess.Popen(['setsid', 'sleep', '40'])\nprint('pid', q.pid, flush=True)\n\
                   p.record(0, e, uv)\ntime.sleep(40)".into(), ""),
    ];
    let names: Vec<String> = cases.iter().map(|c| format!("{:?}", c.0)).collect();
    let mut config = format!(
        "name = \"h\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\ntimeout = \"3s\"\nsolvers = [\"kp-newton\", {}]\n\
         [stop]\nmax_iters = 4\n",
        names.join(", ")
    );
    for (name, body, extra) in &cases {
        let script = hostile(d, name, body);
        config += &external(name, &["python3", &script], extra);
    }
    let cfg = write_config(d, &config);
    let t0 = std::time::Instant::now();
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--jobs", "2", "--no-history"], d);
    let took = t0.elapsed().as_secs_f64();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let (h, rows) = read_csv(&d.join("out/summary.csv"));
    let get = |solver: &str, name: &str| column(&h, &rows, solver, name).to_string();
    let failed = |solver: &str, says: &str| {
        assert_eq!(get(solver, "status"), "failed", "{solver}: {}", get(solver, "error"));
        assert!(get(solver, "error").contains(says), "{solver}: {}", get(solver, "error"));
        assert!(get(solver, "error").len() < 1000, "{solver}: an error of {} bytes", get(solver, "error").len());
    };
    failed("unmapped", "the map of iteration 1 is missing");
    failed("record_s", "plus 1000000 s of record_s is more than the");
    failed("future", "iteration 1: time_s = 1000000000 is past the");
    failed("past_max", "iteration 5 is past max_iters = 4");
    failed("nan_map", "iteration 1: vertex 5 of its map is not finite (NaN)");
    failed("inf_map", "iteration 1: vertex 7 of its map is not finite (inf)");
    failed("mirror", "but its map has inf (2037 flipped faces)");
    failed("unmapped", "(due: the first, the last and every snapshot_every = 1)");
    failed("reversed", "iteration 1: the solver reported energy");
    failed("fifo", "maps/1.uv: is a FIFO, socket or device, not a regular file");
    failed("devzero", "maps/1.uv: is a symbolic link, not a regular file");
    failed("long_line", "iterations.jsonl: 20000069 bytes, more than the 24576 it may have");
    failed("wide", "line 1: 40 extra keys, more than the 32 a record may have");
    failed("long_message", "result.json: 20000039 bytes, more than the 65536 it may have");
    failed("crash_long", "crash_long exited with code 1 (its last error line: zzz");
    failed("crash_long", "... (65236 more characters))");
    failed("processes", "processes was killed with more than 8 processes at once (`processes`)");
    failed("big_file", "File too large");
    assert_eq!(get("no_module", "status"), "skipped");
    assert!(
        get("no_module", "error").contains("No module named 'no_such_module_xyz'"),
        "{}",
        get("no_module", "error")
    );
    // the ones that solved honestly after their tries: judged like any run, confined
    for solver in ["outside", "escape"] {
        assert_eq!(get(solver, "stop_reason"), "max_iters", "{solver}: {}", get(solver, "error"));
        // the kernel's protections (signals from Linux 6.12, sockets by path from 7.1) vary
        assert!(get(solver, "confined").starts_with("writes reads tracing"), "{}", get(solver, "confined"));
        assert!(get(solver, "cpu_s").parse::<f64>().unwrap() > 0.0);
    }
    // one process each: within its thread (a run past it depends on free cores, so the
    // check itself is `confine`'s unit test)
    for solver in ["outside", "escape"] {
        assert!(get(solver, "confined").split(' ').any(|p| p == "threads"), "{}", get(solver, "confined"));
    }
    let said = std::fs::read_to_string(d.join("out/external/bumpy_1k__sd__outside.stdout.txt")).unwrap();
    assert!(!said.contains("wrote"), "{said}");
    assert_eq!(said.matches("refused").count(), 4, "{said}");
    let problem = d.join("out/external/bumpy_1k__sd__outside");
    assert!(said.contains(&format!("HOME {}", problem.join("home").display())), "{said}");
    assert!(said.contains(&format!("TMPDIR {}", problem.join("tmp").display())), "{said}");
    for var in ["OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"] {
        assert!(said.contains(&format!("{var} 1")), "{said}");
    }
    // the other runs' files as they were, nothing outside the problem folders
    assert!(!marker.exists());
    assert!(!std::fs::read_to_string(d.join("out/runs/bumpy_1k__sd__kp-newton.csv")).unwrap().contains("HACKED"));
    assert!(!std::fs::read_to_string(d.join("out/summary.csv")).unwrap().contains("HACKED"));
    assert_eq!(get("kp-newton", "stop_reason"), "max_iters", "{}", get("kp-newton", "error"));
    assert_eq!(read_csv(&d.join("out/runs/bumpy_1k__sd__kp-newton.csv")).1.len(), 5);
    let left: Vec<String> = std::fs::read_dir(d.join("out/external"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".stdout.txt") && !n.ends_with(".stderr.txt"))
        .collect();
    assert!(left.is_empty(), "left in external/: {left:?}");
    // no process of theirs outlived the batch
    for solver in ["escape", "pipes"] {
        let said = std::fs::read_to_string(d.join(format!("out/external/bumpy_1k__sd__{solver}.stdout.txt"))).unwrap();
        let pid = said.split_whitespace().nth(1).unwrap();
        let state = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        assert!(state.is_empty() || state.contains(") Z"), "{solver}'s process {pid} outlived its run: {state}");
    }
    // the timeout held while the pipes stayed open
    assert_eq!(get("pipes", "stop_reason"), "timeout");
    let t: f64 = get("pipes", "time_s").parse().unwrap();
    assert!(t < 4.0, "pipes: {t} s");
    assert!(took < 60.0, "the batch took {took} s");
    let index = std::fs::read_to_string(d.join("out/index.html")).unwrap();
    assert!(index.contains("<h2 id=\"external\">External solvers</h2>"));
}
