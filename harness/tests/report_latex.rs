//! Every table of the report has a `.tex` twin a paper can take: booktabs, its text escaped,
//! a wide table cut into blocks of whole solvers. Each twin of a 10-solver batch is checked
//! for its structure, and compiled by `pdflatex` in a stock `article` when it is installed
//! (`.ci/run` installs it and sets `MAPBENCH_REQUIRE_LATEX=1`, which turns a missing
//! `pdflatex` into a failure instead of a skip).

use crate::common;

use common::{mapbench, text, write_config};
use std::io::Write;
use std::path::Path;
use std::process::Command;

/// The checks that need no LaTeX: one `table` float, each `tabular` opened, ruled and closed,
/// every row with as many cells as its tabular's column specification.
fn check_structure(stem: &str, tex: &str) {
    assert_eq!(tex.matches("\\begin{table}").count(), 1, "{stem}");
    assert!(tex.trim_end().ends_with("\\end{table}"), "{stem}");
    assert!(tex.contains(&format!("\\label{{tab:{}}}", stem.replace('_', "-"))), "{stem}");
    let opened = tex.matches("\\begin{tabular}").count();
    assert!(opened >= 1, "{stem}");
    for k in ["\\toprule", "\\midrule", "\\bottomrule", "\\end{tabular}"] {
        assert_eq!(tex.matches(k).count(), opened, "{stem}: {k}");
    }
    for block in tex.split("\\begin{tabular}{").skip(1) {
        let spec: String = block.chars().take_while(|c| *c != '}').collect();
        assert!(spec.chars().all(|c| c == 'l' || c == 'r'), "{stem}: {spec}");
        let body = &block[..block.find("\\end{tabular}").unwrap()];
        for line in body.lines().filter(|l| l.ends_with("\\\\")) {
            // `\&` is text; an unescaped `&` separates cells.
            let cells = line.replace("\\&", "").matches('&').count() + 1;
            assert_eq!(cells, spec.len(), "{stem}: {line}");
        }
    }
}

/// `pdflatex` of `\input{stem}` in a stock article with booktabs; the log on failure.
fn compile(dir: &Path, stem: &str) -> Result<(), String> {
    let doc = format!(
        "\\documentclass{{article}}\n\\usepackage[margin=1cm,landscape]{{geometry}}\n\\usepackage{{booktabs}}\n\
         \\begin{{document}}\n\\input{{{stem}}}\n\\end{{document}}\n"
    );
    let main = format!("main_{stem}");
    std::fs::write(dir.join(format!("{main}.tex")), doc).unwrap();
    let o = Command::new("pdflatex")
        .args(["-interaction=nonstopmode", "-halt-on-error", &format!("{main}.tex")])
        .current_dir(dir)
        .output()
        .expect("pdflatex runs");
    if o.status.success() && dir.join(format!("{main}.pdf")).exists() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&o.stdout).lines().rev().take(30).collect::<Vec<_>>().join("\n"))
    }
}

#[test]
fn every_table_has_a_latex_twin_that_compiles() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"tex\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\"]\n\
         solvers = [\"kp-newton\", \"kp-newton-noscale\", \"fp-newton-4x4\", \"cm\", \"slim\", \"akvf\", \"newton\", \
         \"pn-abs\", \"lbfgs\", \"aqp\"]\n[stop]\nmax_iters = 30\n",
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], tmp.path());
    assert!(o.status.success(), "{}", text(&o));
    let tables = out.join("tables");
    let mut stems: Vec<String> = std::fs::read_dir(&tables)
        .unwrap()
        .filter_map(|e| e.unwrap().file_name().to_str()?.strip_suffix(".csv").map(String::from))
        .collect();
    stems.sort();
    assert!(stems.len() >= 5 && stems.contains(&"per_mesh".to_string()), "{stems:?}");
    for stem in &stems {
        let tex = std::fs::read_to_string(tables.join(format!("{stem}.tex"))).unwrap_or_else(|e| panic!("{stem}: {e}"));
        check_structure(stem, &tex);
    }
    // Ten solvers of three columns each do not fit one block.
    let per_mesh = std::fs::read_to_string(tables.join("per_mesh.tex")).unwrap();
    assert!(per_mesh.matches("\\begin{tabular}").count() > 1, "{per_mesh}");
    let found = Command::new("pdflatex").arg("--version").output().is_ok_and(|o| o.status.success());
    if !found {
        assert!(std::env::var("MAPBENCH_REQUIRE_LATEX").is_err(), "pdflatex is required but not installed");
        let _ = writeln!(
            std::io::stderr(),
            "skipped compiling: no pdflatex on PATH (Debian's texlive-latex-base and texlive-latex-recommended)"
        );
        return;
    }
    for stem in &stems {
        if let Err(log) = compile(&tables, stem) {
            panic!("{stem}.tex does not compile:\n{log}");
        }
    }
}
