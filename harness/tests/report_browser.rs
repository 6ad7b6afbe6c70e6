//! The report page in a real browser: a small batch's `index.html` opened by headless
//! Chromium, every image must load, every in-page link must resolve and the tables must be
//! there; the next night's page, with 18 solvers and a made regression, opens on what changed
//! and nothing on it scrolls sideways in a 1400-pixel window; its explorer draws a problem's
//! curves, hides a solver when its legend entry is clicked and shows values on hover.
//! Screenshots go to `target/ci-artifacts/report.png`, `first-screen.png` and `explorer.png`
//! for people to look at.
//!
//! Needs Debian's `chromium` (`.ci/run` installs it and sets `MAPBENCH_REQUIRE_CHROMIUM=1`,
//! which turns a missing browser into a failure instead of a skip).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Appended to a copy of the page: once loaded, force lazy images to load, wait for all,
/// and write what it found into the DOM for `--dump-dom`.
const CHECK_SCRIPT: &str = r##"<script>
window.addEventListener('load', async () => {
  const imgs = [...document.images];
  imgs.forEach(i => i.loading = 'eager');
  await Promise.all(imgs.map(i => i.complete ? null : new Promise(r => { i.onload = r; i.onerror = r; })));
  const broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src'));
  const titles = [...document.querySelectorAll('h3')].map(h => h.textContent);
  const changes = document.getElementById('changes');
  const status = document.querySelector('table.status');
  const box = status ? status.parentElement : null;
  const unresolved = [...document.querySelectorAll('a[href^="#"]')].map(a => a.getAttribute('href').slice(1))
    .filter(id => id && !document.getElementById(decodeURIComponent(id)));
  const wide = [...document.querySelectorAll('.scroll')].filter(b => b.scrollWidth > b.clientWidth + 1)
    .map(b => (b.querySelector('table') || b).className || b.innerText.slice(0, 40));
  const pre = document.createElement('pre');
  pre.id = 'mapbench-check';
  pre.textContent = JSON.stringify({
    images: imgs.length, broken, tables: document.querySelectorAll('table').length, titles,
    viewport: [innerWidth, innerHeight],
    page_width: document.documentElement.scrollWidth,
    changes_top: changes ? changes.getBoundingClientRect().top : null,
    status_width: status ? status.getBoundingClientRect().width : null,
    status_box: box ? [box.clientWidth, box.scrollWidth] : null,
    unresolved, wide,
    explorer_links: document.querySelectorAll('a[href^="explorer.html#p="]').length,
  });
  document.body.appendChild(pre);
});
</script>"##;

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
        // past the test harness's capture, which keeps a passing test's `eprintln!` to itself
        let _ =
            writeln!(std::io::stderr(), "skipped: no chromium on PATH (install Debian's `chromium` to run this test)");
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
    let report = check(&browser, &out, (1200, 2400));
    // 2 datasets x 2 energies: 3 curve plots each, plus the group's map (maps = "best": one
    // per dataset and energy), plus the performance profiles
    assert!(report["images"].as_u64().unwrap() >= 16, "{report}");
    assert!(page.matches("__map.png\"").count() >= 4, "every group's map is shown");
    assert_eq!(report["broken"], serde_json::json!([]), "{report}");
    assert!(report["tables"].as_u64().unwrap() >= 3, "status matrix and paper tables: {report}");
    let titles = report["titles"].to_string();
    assert!(titles.contains("Table 4") && titles.contains("Table 1"), "{titles}");
    assert!(page.contains("quad.obj"), "the failed run names its file");
    assert_eq!(report["unresolved"], serde_json::json!([]), "in-page links without their anchor: {report}");
    // A screenshot for people (CI keeps target/ci-artifacts/).
    let artifacts = root.join("target/ci-artifacts");
    std::fs::create_dir_all(&artifacts).unwrap();
    screenshot(&browser, &out, (1200, 2400), &artifacts.join("report.png"));
    first_screen(&browser, tmp.path(), &artifacts);
}

/// A screenshot of `dir/index.html` in a `width` x `height` window, to `shot`.
fn screenshot(browser: &Path, dir: &Path, (width, height): (u32, u32), shot: &Path) {
    let _ = std::fs::remove_file(shot);
    let o = headless(browser)
        .arg(format!("--window-size={width},{height}"))
        .arg("--virtual-time-budget=20000")
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", dir.join("index.html").display()))
        .output()
        .unwrap();
    assert!(shot.is_file(), "no screenshot: {}", String::from_utf8_lossy(&o.stderr));
}

/// What the check script found in the page `dir/index.html` in a `width` x `height` window.
fn check(browser: &Path, dir: &Path, size: (u32, u32)) -> serde_json::Value {
    check_page(browser, dir, "index.html", "", CHECK_SCRIPT, size)
}

/// What `script` (which writes its findings into `<pre id="mapbench-check">`) found in the
/// page `dir/<page><fragment>`, run from a copy beside it so its relative links hold.
fn check_page(
    browser: &Path,
    dir: &Path,
    page: &str,
    fragment: &str,
    script: &str,
    (width, height): (u32, u32),
) -> serde_json::Value {
    let html = std::fs::read_to_string(dir.join(page)).unwrap();
    let check = dir.join(format!("check-{page}"));
    std::fs::write(&check, html.replace("</body>", &format!("{script}</body>"))).unwrap();
    let dom = headless(browser)
        .arg(format!("--window-size={width},{height}"))
        .args(["--virtual-time-budget=20000", "--dump-dom"])
        .arg(format!("file://{}{fragment}", check.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&dom.stdout);
    let marker = "<pre id=\"mapbench-check\">";
    let start = dom.find(marker).expect("the check script ran") + marker.len();
    let json = &dom[start..start + dom[start..].find("</pre>").unwrap()];
    serde_json::from_str(&json.replace("&quot;", "\"").replace("&amp;", "&")).unwrap()
}

/// Two nights of 18 solvers, the second with a made regression (a tighter iteration cap):
/// in a 1400 x 900 window its page opens on the changes, the regressions and the problems,
/// and nothing scrolls sideways, the status matrix included.
fn first_screen(browser: &Path, tmp: &Path, artifacts: &Path) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let solvers = [
        "kp-newton",
        "kp-newton-cg",
        "kp-newton-cg-laplacian",
        "kp-newton-noscale",
        "kp-newton-eig8",
        "fp-newton-4x4",
        "fp-newton-6x6",
        "cm",
        "newton",
        "slim",
        "akvf",
        "pn-abs",
        "fp-abs-6x6",
        "pn-trust-region",
        "fp-trust-region-6x6",
        "lbfgs",
        "lbfgs-laplacian",
        "aqp",
    ];
    let night = |max_iters: usize, out: &str, repeat: &str| {
        let cfg = tmp.join("night.toml");
        std::fs::write(
            &cfg,
            format!(
                "registry = {:?}\nname = \"night\"\ndatasets = [\"bumpy_1k\", \"cap_2k\", \"strip_thin\"]\n\
                 energies = [\"sd\", \"nh\"]\nsolvers = {:?}\n[stop]\nmax_iters = {max_iters}\n",
                root.join("datasets.toml").display().to_string(),
                solvers
            ),
        )
        .unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_mapbench"))
            .args(["run", cfg.to_str().unwrap(), "--out", out, "--repeat", repeat])
            .current_dir(tmp)
            .env_remove("MAPBENCH_MESHES")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        tmp.join(out)
    };
    night(100, "night-1", "1");
    // Timed twice: the explorer draws the repeats' spread.
    let out = night(8, "night-2", "2");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    // The history in tmp/reports has the first test batch as 1: the nights are 2 and 3.
    assert!(page.contains("since batch 2"), "the changes since the first night");
    assert!(page.contains("regression") && !page.contains("<b>0 regressions</b>"), "a regression is named");
    let report = check(browser, &out, (1400, 900));
    assert_eq!(report["broken"], serde_json::json!([]), "{report}");
    let top = report["changes_top"].as_f64().expect("a changes section");
    assert!(top < 400.0, "the changes open the page: {report}");
    let width = report["viewport"][0].as_f64().unwrap();
    assert!(report["page_width"].as_f64().unwrap() <= width, "the page scrolls sideways: {report}");
    let [inside, content] = [0, 1].map(|i| report["status_box"][i].as_f64().unwrap());
    assert!(content <= inside, "the status matrix of 18 solvers scrolls sideways: {report}");
    assert_eq!(report["wide"], serde_json::json!([]), "a box that scrolls sideways: {report}");
    assert_eq!(report["unresolved"], serde_json::json!([]), "in-page links without their anchor: {report}");
    assert_eq!(report["explorer_links"].as_u64(), Some(3 * 2 * 18), "every status cell opens the explorer: {report}");
    screenshot(browser, &out, (1400, 900), &artifacts.join("first-screen.png"));
    explorer(browser, &out, artifacts);
}

/// Run in the explorer once its chart is drawn: the curves drawn, then a click on the first
/// solver's legend entry and a mouse move over the plot, with what each did.
const EXPLORER_SCRIPT: &str = r#"<script>
window.addEventListener('load', () => setTimeout(() => {
  const u = window.mapbenchChart, out = {};
  out.chart = !!u && !!document.querySelector('#chart canvas');
  if (u) {
    const title = u.root.querySelector('.u-title');
    out.title = title ? title.textContent : null;
    out.curves = u.series.length - 1;
    out.points = u.data.slice(1).map(s => s.filter(v => v != null).length);
    out.log_y = u.scales.y.distr;
    const rows = [...u.root.querySelectorAll('.u-legend tr.u-series')];
    out.legend = rows.length;
    rows[1].querySelector('th').click();
    out.markers_before = window.mapbenchMarkers;
    out.hidden_after_click = u.series[1].show === false && rows[1].classList.contains('u-off');
    out.others_shown = u.series.slice(2).every(s => s.show);
    const r = u.over.getBoundingClientRect();
    const at = {clientX: r.left + r.width * 0.05, clientY: r.top + r.height / 2, bubbles: true};
    u.over.dispatchEvent(new MouseEvent('mouseenter', at));
    u.over.dispatchEvent(new MouseEvent('mousemove', at));
  }
  setTimeout(() => {
    if (u) {
      out.cursor_idx = u.cursor.idx;
      out.hover_values = [...u.root.querySelectorAll('.u-legend tr.u-series td.u-value')].map(td => td.textContent);
    }
    out.table_rows = document.querySelectorAll('#runs tr').length - 1;
    const x = document.getElementById('x');
    x.value = 'time';
    x.dispatchEvent(new Event('change'));
    setTimeout(() => {
      out.spreads = window.mapbenchSpreads;
      out.log_x_time = window.mapbenchChart.scales.x.distr;
      const pre = document.createElement('pre');
      pre.id = 'mapbench-check';
      pre.textContent = JSON.stringify(out);
      document.body.appendChild(pre);
    }, 300);
  }, 300);
}, 300));
</script>"#;

/// The explorer of the 18-solver night on bumpy_1k / sd: every solver's curve on a log gap
/// axis, a legend click hides that one alone, a mouse move shows numbers in the legend, and
/// against time each run's repeats' spread.
fn explorer(browser: &Path, out: &Path, artifacts: &Path) {
    let report = check_page(browser, out, "explorer.html", "#p=bumpy_1k__sd", EXPLORER_SCRIPT, (1400, 900));
    assert_eq!(report["chart"], true, "no chart drawn: {report}");
    assert!(report["title"].as_str().is_some_and(|t| t.starts_with("bumpy_1k / sd")), "{report}");
    // One curve per run of the problem that ran to a stop.
    let mut summary = csv::Reader::from_path(out.join("summary.csv")).unwrap();
    let head = summary.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (d, e, s, k) = (col("dataset"), col("energy"), col("status"), col("repeats"));
    let rows: Vec<csv::StringRecord> = summary
        .records()
        .map(|r| r.unwrap())
        .filter(|r| &r[d] == "bumpy_1k" && &r[e] == "sd" && ["ok", "not_converged", "budget"].contains(&&r[s]))
        .collect();
    let ran = rows.len() as u64;
    // Only the runs whose time ranks are timed again (`repeat_runs = "ranked"`).
    let repeated = rows.iter().filter(|r| r[k].parse::<u64>().is_ok_and(|n| n > 1)).count() as u64;
    assert!(repeated >= 1, "no run of bumpy_1k / sd was repeated");
    assert!(ran >= 15, "{ran}");
    assert_eq!(report["curves"].as_u64(), Some(ran), "one curve per run: {report}");
    let points: Vec<u64> = report["points"].as_array().unwrap().iter().map(|n| n.as_u64().unwrap()).collect();
    assert!(points.iter().all(|n| *n >= 1) && points.iter().filter(|n| **n > 2).count() >= 10, "{report}");
    assert_eq!(report["log_y"].as_u64(), Some(3), "a log gap axis: {report}");
    assert_eq!(report["legend"].as_u64(), Some(ran + 1), "the x series and the runs: {report}");
    assert!(report["markers_before"].as_u64().is_some_and(|n| n >= ran), "a marker per curve at least: {report}");
    assert_eq!(report["hidden_after_click"], true, "{report}");
    assert_eq!(report["others_shown"], true, "{report}");
    assert!(report["cursor_idx"].as_u64().is_some(), "the cursor moved onto a point: {report}");
    let values = report["hover_values"].as_array().unwrap();
    let numbers = values.iter().filter(|v| v.as_str().is_some_and(|s| s.chars().any(|c| c.is_ascii_digit()))).count();
    assert!(numbers >= 2, "values under the cursor in the legend: {report}");
    assert_eq!(report["table_rows"].as_u64(), Some(ran), "{report}");
    // Against time (log x), every repeated run's two times drawn as a whisker.
    assert_eq!(report["log_x_time"].as_u64(), Some(3), "{report}");
    assert_eq!(report["spreads"].as_u64(), Some(repeated), "a whisker per repeated run: {report}");
    let shot = artifacts.join("explorer.png");
    let _ = std::fs::remove_file(&shot);
    let o = headless(browser)
        .args(["--window-size=1400,900", "--virtual-time-budget=20000"])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}#p=bumpy_1k__sd", out.join("explorer.html").display()))
        .output()
        .unwrap();
    assert!(shot.is_file(), "no screenshot: {}", String::from_utf8_lossy(&o.stderr));
}
