//! The sandbox holds against a solver that tries to get out (peers/PROTOCOL.md, "The
//! sandbox"): it cannot forge the sandbox's report, stop or kill the sandbox or the harness,
//! read the certified answers or other runs, reach a listener on this machine, leave a process
//! or an IPC object behind, pass its memory cap with many processes, see the harness's
//! environment or print escape sequences to the console; the honest run beside it is what it
//! is alone. A sandbox that dies without a report
//! fails its run.
//!
//! The probes are plain Python (no numpy): these tests run wherever `python3` does.

use crate::common;

use common::*;
use mapbench::external::child::Exit;
use mapbench::external::confine::{self, Limits, Rules};
use mapbench::external::sandbox::{Report, Spec};
use std::io::Read;
use std::process::{Command, Stdio};

/// A solver that tries each way out, prints `refused <what>` or `DID <what>` for each, then
/// exits 1 with escape sequences on its error output. `{...}` are filled in by the test.
const PROBE: &str = r#"
import os, sys, signal, socket, subprocess
folder = sys.argv[-1]
sandbox = os.getppid()
def attempt(what, f):
    try:
        f()
        print('DID', what, flush=True)
    except Exception as e:
        print('refused', what, type(e).__name__, flush=True)
def parent_of(pid):
    return int(open(f'/proc/{pid}/stat').read().rsplit(')', 1)[1].split()[1])
harness = None
def find_harness():
    global harness
    harness = parent_of(sandbox)
attempt('sandbox_stat', find_harness)
def udp():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.sendto(b'x', ('127.0.0.1', {udp}))
def unix(address):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(2)
    s.connect(address)
attempt('forge_report', lambda: open(f'/proc/{sandbox}/fd/1', 'w').write('{"exit": {"Code": 0}}\n'))
attempt('poison_stdin', lambda: open(f'/proc/{sandbox}/fd/0', 'wb').write(b'\xff\xfe\n'))
attempt('sandbox_environ', lambda: open(f'/proc/{sandbox}/environ', 'rb').read())
attempt('harness_environ', lambda: open(f'/proc/{harness}/environ', 'rb').read())
attempt('harness_cmdline', lambda: open(f'/proc/{harness}/cmdline', 'rb').read())
attempt('stop_sandbox', lambda: os.kill(sandbox, signal.SIGSTOP))
attempt('kill_sandbox', lambda: os.kill(sandbox, signal.SIGKILL))
attempt('kill_harness', lambda: os.kill(harness, signal.SIGTERM))
attempt('teleport', lambda: open({reference!r}, 'rb').read())
attempt('other_runs', lambda: os.listdir(os.path.join(folder, '..', '..')))
attempt('tcp', lambda: socket.create_connection(('127.0.0.1', {tcp}), timeout=2))
attempt('udp', udp)
attempt('abstract_socket', lambda: unix({abstract!r}))
attempt('path_socket', lambda: unix({path_socket!r}))
attempt('ipc_left', lambda: subprocess.run(['ipcmk', '-M', '40961'], check=True, capture_output=True))
for argv in (['setsid', 'sleep', '300'], [sys.executable, '-c', 'while True: pass']):
    q = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    print('left', q.pid, flush=True)
print('env', ' '.join(sorted(os.environ)), flush=True)
print('blocked', [l.split()[1] for l in open('/proc/self/status') if l.startswith('SigBlk')][0], flush=True)
sys.stderr.write('\x1b[2J\x1b[31mgone\x1b[0m\n')
sys.exit(1)
"#;

fn solvers_config(solvers: &str, external: &str) -> String {
    format!(
        "name = \"s\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\ntimeout = \"30s\"\nsolvers = [{solvers}]\n\
         [stop]\nmax_iters = 6\n{external}"
    )
}

fn row<'a>(h: &[String], rows: &'a [Vec<String>], solver: &str) -> impl Fn(&str) -> String + 'a {
    let r = rows.iter().find(|r| r[h.iter().position(|c| c == "solver").unwrap()] == solver).unwrap().clone();
    let h = h.to_vec();
    move |c: &str| r[h.iter().position(|x| x == c).unwrap_or_else(|| panic!("no column {c}"))].clone()
}

fn gone(pid: &str) -> bool {
    let state = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    state.is_empty() || state.contains(") Z")
}

#[test]
fn a_solver_that_tries_every_way_out_fails_alone_and_gets_nowhere() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let reference = std::fs::read_dir(repo_root().join("references"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().ends_with(".uv.gz"))
        .expect("a committed reference map");
    let tcp = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    tcp.set_nonblocking(true).unwrap();
    let udp = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    udp.set_nonblocking(true).unwrap();
    let abstract_name = format!("mapbench-sandbox-test-{}", std::process::id());
    let abstract_addr =
        <std::os::unix::net::SocketAddr as std::os::linux::net::SocketAddrExt>::from_abstract_name(&abstract_name)
            .unwrap();
    let abstract_listener = std::os::unix::net::UnixListener::bind_addr(&abstract_addr).unwrap();
    abstract_listener.set_nonblocking(true).unwrap();
    let path_socket = d.join("listener.sock");
    let path_listener = std::os::unix::net::UnixListener::bind(&path_socket).unwrap();
    path_listener.set_nonblocking(true).unwrap();
    let probe = PROBE
        .replace("{udp}", &udp.local_addr().unwrap().port().to_string())
        .replace("{tcp}", &tcp.local_addr().unwrap().port().to_string())
        .replace("{reference!r}", &format!("{:?}", reference.display().to_string()))
        .replace("{abstract!r}", &format!("'\\0{abstract_name}'"))
        .replace("{path_socket!r}", &format!("{:?}", path_socket.display().to_string()));
    std::fs::create_dir_all(d.join("peer")).unwrap();
    std::fs::write(d.join("peer/probe.py"), probe).unwrap();
    // four processes of 60 MB each, under a cap of 150 MiB for them together
    // 1 MiB files, each well under `file_size_mb`, past 20 MiB together
    std::fs::write(
        d.join("peer/filler.py"),
        "import os, sys, time\nfor i in range(200):\n    open(os.path.join(sys.argv[-1], f'fill{i}'), 'wb').write(os.urandom(1 << 20))\ntime.sleep(30)\n",
    )
    .unwrap();
    std::fs::write(
        d.join("peer/hog.py"),
        "import subprocess, sys, time\nkid = \"b = b'x' * 60_000_000\\nimport time\\ntime.sleep(30)\"\n\
         ps = [subprocess.Popen([sys.executable, '-c', kid]) for _ in range(4)]\ntime.sleep(30)\n",
    )
    .unwrap();
    let external = "[external.probe]\ncommand = [\"python3\", \"peer/probe.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n\
                    [external.hog]\ncommand = [\"python3\", \"peer/hog.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n\
                    memory_mb = 150\n\
                    [external.filler]\ncommand = [\"python3\", \"peer/filler.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n\
                    disk_mb = 20\n";
    let cfg = write_config(d, &solvers_config("\"kp-newton\", \"probe\", \"hog\", \"filler\"", external));
    let o = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", "out", "--history", "h.sqlite", "--jobs", "2"])
        .current_dir(d)
        .env_remove("MAPBENCH_MESHES")
        .env("MAPBENCH_TEST_SECRET", "a token the solver must not see")
        .output()
        .unwrap();
    let log = text(&o);
    assert_eq!(o.status.code(), Some(1), "{log}");
    assert!(!log.contains('\u{1b}'), "an escape sequence reached the console: {log:?}");
    let (h, rows) = read_csv(&d.join("out/summary.csv"));
    let get = row(&h, &rows, "probe");
    assert_eq!(get("status"), "failed", "{}", get("error"));
    assert!(get("error").contains("probe exited with code 1 (its last error line: \\u{1b}[2J"), "{}", get("error"));
    assert!(!std::fs::read_to_string(d.join("out/summary.csv")).unwrap().contains('\u{1b}'));
    let hog = row(&h, &rows, "hog");
    assert_eq!(hog("status"), "failed", "{}", hog("error"));
    let too_much = "hog was killed with more than 150 MiB resident in its processes together";
    assert!(hog("error").contains(too_much), "{}", hog("error"));
    let filler = row(&h, &rows, "filler");
    assert_eq!(filler("status"), "failed", "{}", filler("error"));
    assert!(filler("error").contains("filler was killed with more than 20 MiB in its problem folder (`disk_mb`)"));
    // the batch is recorded, its hostile runs with it
    assert!(log.contains("history: batch 1 (4 runs of s) appended to"), "{log}");
    let said = std::fs::read_to_string(d.join("out/external/bumpy_1k__sd__probe.stdout.txt")).unwrap();
    for what in [
        "forge_report",
        "poison_stdin",
        "sandbox_stat",
        "sandbox_environ",
        "harness_environ",
        "harness_cmdline",
        "stop_sandbox",
        "kill_sandbox",
        "kill_harness",
        "teleport",
        "other_runs",
        "tcp",
        "udp",
        "abstract_socket",
    ] {
        assert!(said.contains(&format!("refused {what} ")), "{what}: {said}");
    }
    // nothing reached the listeners
    assert!(tcp.accept().is_err() && abstract_listener.accept().is_err());
    assert!(udp.recv(&mut [0u8; 8]).is_err());
    // a socket named by a path is closed to it only where the kernel's Landlock can (ABI 9)
    let by_path = path_listener.accept().is_ok();
    assert_eq!(by_path, said.contains("DID path_socket"), "{said}");
    // the environment is the sandbox's alone, the signals the solver's to handle
    let env = said.lines().find_map(|l| l.strip_prefix("env ")).unwrap();
    let names: Vec<&str> = env.split(' ').collect();
    for name in ["PATH", "HOME", "TMPDIR", "OMP_NUM_THREADS", "PYTHONDONTWRITEBYTECODE"] {
        assert!(names.contains(&name), "{name} missing: {env}");
    }
    for name in ["MAPBENCH_TEST_SECRET", "PYTHONUSERBASE", "CARGO_MANIFEST_DIR", "RUST_BACKTRACE"] {
        assert!(!names.contains(&name), "{name} passed on: {env}");
    }
    assert!(said.contains("blocked 0000000000000000"), "{said}");
    // what it left behind ended with its run (the CPU burner included)
    let left: Vec<&str> = said.lines().filter_map(|l| l.strip_prefix("left ")).collect();
    assert_eq!(left.len(), 2, "{said}");
    for pid in left {
        assert!(gone(pid), "process {pid} outlived its run");
    }
    // a SysV segment it made is gone with it (an IPC namespace of its own)
    let segments = std::fs::read_to_string("/proc/sysvipc/shm").unwrap_or_default();
    assert!(!segments.lines().any(|l| l.split_whitespace().nth(3) == Some("40961")), "{said}\n{segments}");
    // the honest run beside it is the one it is alone
    let alone = write_config(d, &solvers_config("\"kp-newton\"", ""));
    let o = mapbench(&["run", alone.to_str().unwrap(), "--out", "alone", "--no-history"], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h2, rows2) = read_csv(&d.join("alone/summary.csv"));
    let (beside, solo) = (row(&h, &rows, "kp-newton"), row(&h2, &rows2, "kp-newton"));
    for c in ["status", "stop_reason", "iterations", "final_energy", "grad_norm", "flips"] {
        assert_eq!(beside(c), solo(c), "{c}");
    }
}

/// The sandbox killed from outside (the OOM killer, an operator): the run fails with the reason,
/// it is not skipped, and the batch goes on.
#[test]
fn a_sandbox_that_dies_without_a_report_fails_its_run() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let external =
        "[external.sleeper]\ncommand = [\"sh\", \"-c\", \"sleep 61\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n";
    let cfg = write_config(d, &solvers_config("\"sleeper\"", external));
    let mut child = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", "out", "--no-history"])
        .current_dir(d)
        .env_remove("MAPBENCH_MESHES")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let me = child.id().to_string();
    let t0 = std::time::Instant::now();
    let sandbox = loop {
        let found = std::fs::read_dir("/proc").unwrap().flatten().find_map(|e| {
            let pid = e.file_name().to_string_lossy().into_owned();
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
            let parent = stat.rsplit_once(')')?.1.split_whitespace().nth(1)?.to_string();
            (parent == me && cmdline.ends_with(b"\0sandbox\0")).then_some(pid)
        });
        if let Some(pid) = found {
            break pid;
        }
        assert!(t0.elapsed().as_secs() < 60, "no sandbox process");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert!(Command::new("kill").args(["-KILL", &sandbox]).status().unwrap().success());
    let mut log = String::new();
    let status = child.wait().unwrap();
    child.stderr.take().unwrap().read_to_string(&mut log).unwrap();
    assert_eq!(status.code(), Some(1), "{log}");
    assert!(t0.elapsed().as_secs() < 50, "the batch waited for the solver: {log}");
    let (h, rows) = read_csv(&d.join("out/summary.csv"));
    let get = row(&h, &rows, "sleeper");
    assert_eq!(get("status"), "failed", "{}", get("error"));
    assert!(get("error").contains("ended without a report"), "{}", get("error"));
    // the solver went with its sandbox
    std::thread::sleep(std::time::Duration::from_millis(300));
    let sleeping = std::fs::read_dir("/proc").unwrap().flatten().any(|e| {
        std::fs::read(e.path().join("cmdline")).is_ok_and(|c| c == b"sleep\x0061\0")
            && !gone(&e.file_name().to_string_lossy())
    });
    assert!(!sleeping, "the solver outlived its sandbox");
}

/// `mapbench sandbox` run directly, as the harness runs it: `script` in Python on a problem
/// folder under `limits`; its report.
fn sandboxed(folder: &std::path::Path, script: &str, limits: Limits) -> Report {
    use std::io::Write;
    std::fs::write(folder.join("solver.py"), script).unwrap();
    let command = vec!["python3".to_string(), folder.join("solver.py").display().to_string()];
    let rules = Rules {
        writable: Some(folder.to_path_buf()),
        readable: confine::readable(&command, folder, &[]),
        network: false,
        limits,
    };
    let spec = Spec {
        command,
        cwd: folder.to_path_buf(),
        rules,
        env: confine::base_environment(),
        timeout_s: Some(60.0),
        keep: 4096,
    };
    let mut sandbox = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .arg("sandbox")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // the sandbox stops the run when its standard input closes: kept open until it reports
    let mut stdin = sandbox.stdin.take().unwrap();
    stdin.write_all((serde_json::to_string(&spec).unwrap() + "\n").as_bytes()).unwrap();
    let mut report = String::new();
    sandbox.stdout.take().unwrap().read_to_string(&mut report).unwrap();
    drop(stdin);
    assert!(sandbox.wait().unwrap().success());
    serde_json::from_str(&report).unwrap_or_else(|e| panic!("{e}: {report}"))
}

/// What the sandbox measures it measures from outside, of every process: the CPU time of a
/// child nobody waits for counts, and the problem folder's size is capped for all its files.
#[test]
fn the_sandbox_counts_what_no_parent_waits_for_and_caps_the_folder() {
    let tmp = tempfile::tempdir().unwrap();
    // a child that burns 1 s of CPU, its parent ignoring SIGCHLD: the kernel reaps it, and its
    // time reaches no getrusage
    let burner = "import os, signal, time\nsignal.signal(signal.SIGCHLD, signal.SIG_IGN)\npid = os.fork()\n\
                  if pid == 0:\n    t = time.process_time()\n    while time.process_time() - t < 1.0: pass\n    os._exit(0)\n\
                  while True:\n    try: os.kill(pid, 0)\n    except ProcessLookupError: break\n    time.sleep(0.02)\n";
    let r = sandboxed(tmp.path(), burner, Limits::default());
    assert_eq!(r.exit, Some(Exit::Code(0)), "{r:?}");
    assert!(r.cpu_s >= 0.9, "{r:?}");
    let filler = "import os, sys, time\nfor i in range(100):\n    open(f'fill{i}', 'wb').write(os.urandom(1 << 20))\ntime.sleep(30)\n";
    let r = sandboxed(tmp.path(), filler, Limits { disk_mb: Some(10), ..Limits::default() });
    assert_eq!(r.exit, Some(Exit::TooMuchDisk(10)), "{r:?}");
    assert!(r.wall_s < 20.0, "{r:?}");
}
