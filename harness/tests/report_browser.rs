//! The report page in a real browser: a small batch's `index.html` opened by headless
//! Chromium, every image must load and the tables must be there. A screenshot goes to
//! `target/ci-artifacts/report.png` for people to look at.
//!
//! Needs Debian's `chromium` (`.ci/run` installs it and sets `MAPBENCH_REQUIRE_CHROMIUM=1`,
//! which turns a missing browser into a failure instead of a skip).

use std::path::{Path, PathBuf};
use std::process::Command;

/// Appended to a copy of the page: once loaded, force lazy images to load, wait for all,
/// and write what it found into the DOM for `--dump-dom`.
const CHECK_SCRIPT: &str = r#"<script>
window.addEventListener('load', async () => {
  const imgs = [...document.images];
  imgs.forEach(i => i.loading = 'eager');
  await Promise.all(imgs.map(i => i.complete ? null : new Promise(r => { i.onload = r; i.onerror = r; })));
  const broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src'));
  const titles = [...document.querySelectorAll('h3')].map(h => h.textContent);
  const pre = document.createElement('pre');
  pre.id = 'mapbench-check';
  pre.textContent = JSON.stringify({images: imgs.length, broken, tables: document.querySelectorAll('table').length, titles});
  document.body.appendChild(pre);
});
</script>"#;

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"].iter().find_map(|name| {
        let ok = Command::new(name).arg("--version").output().is_ok_and(|o| o.status.success());
        ok.then(|| PathBuf::from(name))
    })
}

fn headless(browser: &Path) -> Command {
    let mut c = Command::new(browser);
    c.args(["--headless", "--no-sandbox", "--disable-gpu", "--allow-file-access-from-files", "--hide-scrollbars"]);
    c
}

#[test]
fn the_report_page_loads_every_image_and_shows_the_tables() {
    let Some(browser) = chromium() else {
        assert!(std::env::var("MAPBENCH_REQUIRE_CHROMIUM").is_err(), "chromium is required but not installed");
        eprintln!("skipped: no chromium on PATH (install Debian's `chromium` to run this test)");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    std::fs::write(tmp.path().join("quad.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let cfg = tmp.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!(
            "registry = {:?}\nname = \"page\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\", \"bconf\"]\n\
             solvers = [\"kp-newton\", \"cm\", \"slim\"]\n[[dataset]]\nname = \"broken\"\npath = \"quad.obj\"\n",
            root.join("datasets.toml").display().to_string()
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()])
        // In the temporary folder: the default history database is reports/ of the cwd.
        .current_dir(tmp.path())
        .env_remove("MAPBENCH_MESHES")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "the broken mesh fails its runs: {}", String::from_utf8_lossy(&o.stderr));
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let check = out.join("check.html");
    std::fs::write(&check, page.replace("</body>", &format!("{CHECK_SCRIPT}</body>"))).unwrap();
    let dom = headless(&browser)
        .args(["--virtual-time-budget=20000", "--dump-dom"])
        .arg(format!("file://{}", check.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&dom.stdout);
    let marker = "<pre id=\"mapbench-check\">";
    let start = dom.find(marker).expect("the check script ran") + marker.len();
    let json = &dom[start..start + dom[start..].find("</pre>").unwrap()];
    let report: serde_json::Value = serde_json::from_str(&json.replace("&quot;", "\"").replace("&amp;", "&")).unwrap();
    // 2 datasets x 2 energies: 3 curve plots each, plus the group's map (maps = "best": one
    // per dataset and energy), plus the performance profiles
    assert!(report["images"].as_u64().unwrap() >= 16, "{report}");
    assert!(page.matches("__map.png\"").count() >= 4, "every group's map is shown");
    assert_eq!(report["broken"], serde_json::json!([]), "{report}");
    assert!(report["tables"].as_u64().unwrap() >= 3, "status matrix and paper tables: {report}");
    let titles = report["titles"].to_string();
    assert!(titles.contains("Table 4") && titles.contains("Table 1"), "{titles}");
    assert!(page.contains("quad.obj"), "the failed run names its file");
    // A screenshot for people (CI keeps target/ci-artifacts/).
    let artifacts = root.join("target/ci-artifacts");
    std::fs::create_dir_all(&artifacts).unwrap();
    let shot = artifacts.join("report.png");
    let _ = std::fs::remove_file(&shot);
    let o = headless(&browser)
        .args(["--window-size=1200,2400", "--virtual-time-budget=20000"])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", out.join("index.html").display()))
        .output()
        .unwrap();
    assert!(shot.is_file(), "no screenshot: {}", String::from_utf8_lossy(&o.stderr));
}
