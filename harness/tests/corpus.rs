//! `mapbench corpus fetch`: the network path against a server on the loopback address (a
//! good file, a corrupted one, a missing one, a connection cut mid-file and the resume), the
//! local path with `--from` on the shared corpus (when `MAPBENCH_MESHES` names it) and a
//! batch on what it installed, and the hint a config gets when its corpus meshes are missing.

use crate::common;

use common::*;
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// What the test server does with a path.
#[derive(Clone)]
enum Serve {
    /// The bytes, with `Range` requests honoured.
    File(Vec<u8>),
    /// The bytes, but the first whole-file answer stops halfway and closes the connection.
    CutOnce(Vec<u8>),
}

/// A loopback HTTP/1.1 server answering `GET` from `files` (404 for other paths), one
/// connection at a time, for at most 40 connections; its log holds `<path> <range>` per
/// request.
fn serve(files: HashMap<String, Serve>) -> (String, Arc<Mutex<Vec<String>>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = format!("http://{}", listener.local_addr().unwrap());
    let log = Arc::new(Mutex::new(Vec::new()));
    let seen = log.clone();
    std::thread::spawn(move || {
        let mut cut = std::collections::HashSet::new();
        for stream in listener.incoming().take(40).flatten() {
            answer(stream, &files, &mut cut, &seen);
        }
    });
    (addr, log)
}

fn answer(
    mut stream: TcpStream,
    files: &HashMap<String, Serve>,
    cut: &mut std::collections::HashSet<String>,
    log: &Mutex<Vec<String>>,
) {
    stream.set_read_timeout(Some(std::time::Duration::from_secs(10))).unwrap();
    let mut reader = BufReader::new(stream.try_clone().unwrap());
    let mut head = Vec::new();
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).unwrap_or(0) == 0 || line == "\r\n" {
            break;
        }
        head.push(line.trim_end().to_string());
    }
    let path = head.first().and_then(|l| l.split_whitespace().nth(1)).unwrap_or("").to_string();
    let from: Option<usize> = head
        .iter()
        .find_map(|l| l.to_ascii_lowercase().strip_prefix("range: bytes=").map(|r| r.trim_end_matches('-').to_string()))
        .and_then(|r| r.parse().ok());
    log.lock().unwrap().push(format!("{path} {}", from.map_or("-".into(), |f| f.to_string())));
    let (bytes, cut_now) = match files.get(&path) {
        None => {
            let _ =
                stream.write_all(b"HTTP/1.1 404 Not Found\r\nContent-Length: 9\r\nConnection: close\r\n\r\nnot found");
            return;
        }
        Some(Serve::File(b)) => (b, false),
        Some(Serve::CutOnce(b)) => (b, from.is_none() && cut.insert(path.clone())),
    };
    let reply = match from {
        Some(k) if k < bytes.len() => [
            format!(
                "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes {k}-{}/{}\r\nContent-Length: {}\r\n\
                 Connection: close\r\n\r\n",
                bytes.len() - 1,
                bytes.len(),
                bytes.len() - k
            )
            .into_bytes(),
            bytes[k..].to_vec(),
        ]
        .concat(),
        _ => {
            let body = if cut_now { &bytes[..bytes.len() / 2] } else { &bytes[..] };
            [
                format!("HTTP/1.1 200 OK\r\nContent-Length: {}\r\nConnection: close\r\n\r\n", bytes.len()).into_bytes(),
                body.to_vec(),
            ]
            .concat()
        }
    };
    let _ = stream.write_all(&reply);
    let _ = stream.flush();
    let _ = stream.shutdown(std::net::Shutdown::Both);
}

fn sha256(bytes: &[u8]) -> String {
    mapbench::corpus::sha256_hex(bytes)
}

/// A source OBJ with what the recipe drops (comments, normals, texture corners), and the plain
/// OBJ it must become, written out by hand.
const SOURCE: &str =
    "# exported\nv 0 0 0\nv 2.0 0 0\nvn 0 0 1\nv 0 2 0\nv 2 2 1.000\nf 1//1 2//1 3//1\nf 2/1 4/2 3/3\n";
const MESH: &str = "# quad: from github.com/owner/repo meshes/quad.obj (commit abc123); see MANIFEST.toml for \
                    license/attribution\nv 0.0 0.0 0.0\nv 2.0 0.0 0.0\nv 0.0 2.0 0.0\nv 2.0 2.0 1.0\nf 1 2 3\nf 2 4 3\n";
/// Its subdivision: midpoints of (1,2) (1,3) (2,3) (2,4) (3,4), faces by corner.
const SUB: &str = "# quad_sub: from github.com/owner/repo meshes/quad.obj (commit abc123); see MANIFEST.toml for \
                   license/attribution\nv 0.0 0.0 0.0\nv 2.0 0.0 0.0\nv 0.0 2.0 0.0\nv 2.0 2.0 1.0\nv 1.0 0.0 0.0\n\
                   v 0.0 1.0 0.0\nv 1.0 1.0 0.0\nv 2.0 1.0 0.5\nv 1.0 2.0 0.5\nf 1 5 6\nf 2 8 7\nf 5 2 7\nf 8 4 9\n\
                   f 6 7 3\nf 7 9 3\nf 5 7 6\nf 8 9 7\n";

/// A manifest of `quad` (from `path` of the server, pinned to `source`) and its subdivision.
fn manifest(dir: &Path, path: &str, source: &[u8]) -> String {
    let mesh = |name: &str, file: &str, text: &str, extra: &str| {
        format!(
            "[[mesh]]\nname = \"{name}\"\nfile = \"{file}\"\n{extra}bytes = {}\nsha256 = \"{}\"\nrepository = \"owner/repo\"\n\
             commit = \"abc123\"\npath = \"{path}\"\nsource_bytes = {}\nsource_sha256 = \"{}\"\nlicense = \"test\"\n",
            text.len(),
            sha256(text.as_bytes()),
            source.len(),
            sha256(source)
        )
    };
    let text = format!(
        "version = 1\n{}{}",
        mesh("quad", "quad.obj", MESH, "recipe = \"obj\"\n"),
        mesh("quad_sub", "quad_sub.obj", SUB, "recipe = \"subdivide\"\nof = \"quad\"\n")
    );
    let p = dir.join("corpus.toml");
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// `mapbench corpus fetch --manifest M --to T` against the server at `url`.
fn fetch(dir: &Path, manifest: &str, to: &Path, url: &str) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["corpus", "fetch", "--manifest", manifest, "--to", to.to_str().unwrap()])
        .current_dir(dir)
        .env("MAPBENCH_CORPUS_URL", format!("{url}/{{repository}}/{{commit}}/{{path}}"))
        .env_remove("MAPBENCH_MESHES")
        .output()
        .unwrap()
}

/// The files of `dir` but the work folder.
fn installed(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|r| r.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    names.retain(|n| n != mapbench::corpus::WORK_DIR);
    names.sort();
    names
}

#[test]
fn the_network_path_installs_a_good_source_and_refuses_a_corrupt_or_missing_one() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let corrupt = SOURCE.replace("2.0", "2.5").into_bytes();
    assert_eq!(corrupt.len(), SOURCE.len());
    let (url, log) = serve(HashMap::from([
        ("/owner/repo/abc123/meshes/quad.obj".to_string(), Serve::File(SOURCE.as_bytes().to_vec())),
        ("/owner/repo/abc123/meshes/corrupt.obj".to_string(), Serve::File(corrupt)),
    ]));

    // a good source: the recipe's files, checked, installed; the work folder gone
    let good = manifest(d, "meshes/quad.obj", SOURCE.as_bytes());
    let o = fetch(d, &good, &d.join("good"), &url);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(installed(&d.join("good")), ["quad.obj", "quad_sub.obj"]);
    assert_eq!(std::fs::read_to_string(d.join("good/quad.obj")).unwrap(), MESH);
    assert_eq!(std::fs::read_to_string(d.join("good/quad_sub.obj")).unwrap(), SUB);
    assert!(text(&o).contains("2 files installed, 0 present already"), "{}", text(&o));
    assert!(text(&o).contains("[1/2] quad: downloading"), "progress: {}", text(&o));
    // again: nothing to download
    let before = log.lock().unwrap().len();
    let o = fetch(d, &good, &d.join("good"), &url);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("0 files installed, 2 present already"), "{}", text(&o));
    assert_eq!(log.lock().unwrap().len(), before);

    // a source that is not the pinned file: refused, deleted, nothing installed
    let bad = manifest(d, "meshes/corrupt.obj", SOURCE.as_bytes());
    let o = fetch(d, &bad, &d.join("bad"), &url);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("not the pinned file, refused"), "{}", text(&o));
    assert_eq!(installed(&d.join("bad")), Vec::<String>::new());
    let downloads = d.join("bad").join(mapbench::corpus::WORK_DIR).join("downloads");
    assert_eq!(std::fs::read_dir(downloads).unwrap().count(), 0, "the corrupt download is deleted");

    // a missing source (404): refused, naming it
    let missing = manifest(d, "meshes/gone.obj", SOURCE.as_bytes());
    let o = fetch(d, &missing, &d.join("missing"), &url);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("meshes/gone.obj: the source is missing (HTTP 404)"), "{}", text(&o));
    assert_eq!(installed(&d.join("missing")), Vec::<String>::new());
}

#[test]
fn a_download_cut_mid_file_installs_nothing_and_the_next_fetch_resumes_it() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (url, log) = serve(HashMap::from([(
        "/owner/repo/abc123/meshes/quad.obj".to_string(),
        Serve::CutOnce(SOURCE.as_bytes().to_vec()),
    )]));
    let m = manifest(d, "meshes/quad.obj", SOURCE.as_bytes());
    let o = fetch(d, &m, &d.join("to"), &url);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("run the command again to resume it"), "{}", text(&o));
    assert_eq!(installed(&d.join("to")), Vec::<String>::new());
    let o = fetch(d, &m, &d.join("to"), &url);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("resuming"), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(d.join("to/quad.obj")).unwrap(), MESH);
    let half = SOURCE.len() / 2;
    assert_eq!(
        *log.lock().unwrap(),
        ["/owner/repo/abc123/meshes/quad.obj -".to_string(), format!("/owner/repo/abc123/meshes/quad.obj {half}")]
    );
}

/// With the shared corpus at hand (`MAPBENCH_MESHES`), `--from` installs every file of the
/// built-in manifest from it, checked, and a batch of `configs/ci.toml` runs on the copy.
#[test]
fn the_shared_corpus_installs_from_a_copy_and_a_config_runs_on_it() {
    let Some(shared) = std::env::var_os("MAPBENCH_MESHES") else {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "skipped: MAPBENCH_MESHES is not set (the shared corpus to copy)");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let to = tmp.path().join("meshes");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["corpus", "fetch", "--from", Path::new(&shared).to_str().unwrap(), "--to", to.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let m = mapbench::corpus::Manifest::built_in().unwrap();
    let files: usize = m.meshes.iter().map(|e| e.outputs().len()).sum();
    assert_eq!(installed(&to).len(), files);
    assert!(text(&o).contains(&format!("{files} files installed")), "{}", text(&o));
    let cfg = repo_root().join("configs/ci.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--only", "cow__sd__kp-newton", "--out", "out", "--no-history"])
        .current_dir(tmp.path())
        .env("MAPBENCH_MESHES", &to)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&tmp.path().join("out/summary.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    // It ran and was judged against the committed reference of the same mesh: the copy's
    // content is the corpus's, so its reference key is too.
    assert_eq!(rows.len(), 1);
    let r = &rows[0];
    assert!(["ok", "not_converged"].contains(&r[col("status")].as_str()), "{r:?}");
    assert_eq!((r[col("ref_source")].as_str(), r[col("ref_certified")].as_str()), ("reference", "true"), "{r:?}");
}

#[test]
fn a_config_whose_corpus_meshes_are_missing_says_how_to_get_them() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"c\"\ndatasets = [\"cow\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("`mapbench corpus fetch --to DIR` installs it"), "{}", text(&o));
}

#[test]
fn the_test_server_reads_its_own_requests() {
    // the helper itself: a whole file, then a range
    let (url, log) = serve(HashMap::from([("/x".to_string(), Serve::File(b"0123456789".to_vec()))]));
    let get = |range: Option<&str>| {
        let mut s = TcpStream::connect(url.trim_start_matches("http://")).unwrap();
        let extra = range.map_or(String::new(), |r| format!("Range: bytes={r}\r\n"));
        s.write_all(format!("GET /x HTTP/1.1\r\nHost: x\r\n{extra}\r\n").as_bytes()).unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    };
    assert!(get(None).ends_with("\r\n\r\n0123456789"));
    let part = get(Some("4-"));
    assert!(part.starts_with("HTTP/1.1 206") && part.ends_with("\r\n\r\n456789"), "{part}");
    assert_eq!(*log.lock().unwrap(), ["/x -", "/x 4"]);
}
