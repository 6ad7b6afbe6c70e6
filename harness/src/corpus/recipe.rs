//! The recipes that made the shared corpus from its sources, byte for byte: a plain OBJ (a
//! header line naming the source, `v x y z` with Python's `repr` of each coordinate, `f a b c`
//! 1-based, in the source's order) from an OBJ or a MATLAB file; one flat midpoint subdivision;
//! and a GLID cage triangulated by Triangle, which runs in Python (`scripts/corpus_glid.py`,
//! built in) since no Rust port of Triangle makes the same mesh.

use super::manifest::{CorpusEntry, Recipe};
use super::mat;
use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The GLID recipe's script, run with `python3`.
pub const GLID_SCRIPT: &str = include_str!("../../../scripts/corpus_glid.py");

/// A mesh as the recipes see it: vertices, and triangles as 1-based indices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obj {
    pub v: Vec<[f64; 3]>,
    pub f: Vec<[i64; 3]>,
}

/// The files of `entry` (its mesh, then its sidecar) from its downloaded `source`; `made`
/// gives the installed bytes of another mesh of the corpus (what `subdivide` starts from).
pub fn build(entry: &CorpusEntry, source: &Path, made: &dyn Fn(&str) -> Result<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
    let read = || std::fs::read(source).with_context(|| format!("{}: cannot read", source.display()));
    match entry.recipe {
        Recipe::Obj => Ok(vec![obj(&header(entry), &parse_obj(&read()?)?)]),
        Recipe::Mat => {
            let vars = mat::read(&read()?)?;
            let get = |name: &str| vars.get(name).with_context(|| format!("no numeric matrix `{name}`"));
            let (v, f) = (get("v")?, get("f")?);
            if v.cols != 3 || f.cols != 3 {
                bail!("`v` is {}x{} and `f` {}x{}: expected n x 3 each", v.rows, v.cols, f.rows, f.cols);
            }
            let vertices: Vec<[f64; 3]> = (0..v.rows).map(|i| [v.at(i, 0), v.at(i, 1), v.at(i, 2)]).collect();
            let faces: Vec<[i64; 3]> = (0..f.rows)
                .map(|i| [0, 1, 2].map(|j| f.at(i, j) as i64))
                .map(|t| if t.iter().all(|&x| x >= 1) { Ok(t) } else { bail!("a face index below 1: {t:?}") })
                .collect::<Result<_>>()?;
            Ok(vec![obj(&header(entry), &Obj { v: vertices, f: faces })])
        }
        Recipe::Subdivide => {
            let of = entry.of.as_deref().context("subdivide without `of`")?;
            Ok(vec![obj(&header(entry), &subdivide(&parse_obj(&made(of)?)?)?)])
        }
        Recipe::Glid => glid(entry, source),
    }
}

/// The first line of a converted mesh: where it came from.
fn header(e: &CorpusEntry) -> String {
    format!(
        "# {}: from github.com/{} {} (commit {}); see MANIFEST.toml for license/attribution\n",
        e.name, e.repository, e.path, e.commit
    )
}

/// The `v` (first three coordinates) and `f` (first index of each corner, 1-based) lines of
/// an OBJ; anything else is left out, a face that is not a triangle is an error.
pub fn parse_obj(bytes: &[u8]) -> Result<Obj> {
    let text = std::str::from_utf8(bytes).context("not UTF-8 text")?;
    let (mut v, mut f) = (Vec::new(), Vec::new());
    for (k, line) in text.lines().enumerate() {
        let at = || format!("line {}", k + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for x in &mut p {
                    let w =
                        words.next().with_context(|| format!("{}: a vertex with fewer than 3 coordinates", at()))?;
                    *x = w.parse().with_context(|| format!("{}: `{w}` is not a number", at()))?;
                }
                v.push(p);
            }
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() != 3 {
                    bail!("{}: a face with {} corners (the recipe takes triangles)", at(), corners.len());
                }
                let mut t = [0i64; 3];
                for (x, w) in t.iter_mut().zip(&corners) {
                    let i = w.split('/').next().unwrap_or_default();
                    *x = i.parse().with_context(|| format!("{}: `{w}` is not a vertex index", at()))?;
                    if *x < 1 {
                        bail!("{}: vertex index {x} (the recipe takes 1-based indices)", at());
                    }
                }
                f.push(t);
            }
            _ => {}
        }
    }
    Ok(Obj { v, f })
}

/// The plain OBJ: `header`, then `v` lines with Python's `repr` of each coordinate, then
/// 1-based `f` lines.
pub fn obj(header: &str, mesh: &Obj) -> Vec<u8> {
    let (v, f) = (&mesh.v, &mesh.f);
    let mut s = String::with_capacity(header.len() + 40 * v.len() + 20 * f.len());
    s += header;
    for p in v {
        let _ = writeln!(s, "v {} {} {}", py_repr(p[0]), py_repr(p[1]), py_repr(p[2]));
    }
    for t in f {
        let _ = writeln!(s, "f {} {} {}", t[0], t[1], t[2]);
    }
    s.into_bytes()
}

/// One flat 1-to-4 subdivision (1-based faces): the vertices, then one midpoint per edge in
/// sorted-edge order; the faces `[a, ab, ca]` of every triangle, then every `[ab, b, bc]`,
/// every `[ca, bc, c]` and every `[ab, bc, ca]`.
pub fn subdivide(mesh: &Obj) -> Result<Obj> {
    let (v, f) = (&mesh.v, &mesh.f);
    let n = v.len() as i64;
    if let Some(t) = f.iter().find(|t| t.iter().any(|&x| x > n)) {
        bail!("a face {t:?} names a vertex beyond the {n} there are");
    }
    let key = |a: i64, b: i64| (a.min(b), a.max(b));
    let mut edges: BTreeMap<(i64, i64), i64> =
        f.iter().flat_map(|t| [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])]).map(|e| (e, 0)).collect();
    let mut vertices = v.to_vec();
    for (k, ((a, b), id)) in edges.iter_mut().enumerate() {
        *id = n + 1 + k as i64;
        let (p, q) = (v[*a as usize - 1], v[*b as usize - 1]);
        vertices.push([0, 1, 2].map(|i| (p[i] + q[i]) / 2.0));
    }
    let mid = |a: i64, b: i64| edges[&key(a, b)];
    let mut faces = Vec::with_capacity(4 * f.len());
    for corner in 0..4 {
        for &[a, b, c] in f.iter() {
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            faces.push([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]][corner]);
        }
    }
    Ok(Obj { v: vertices, f: faces })
}

/// Python's `repr` of a float: the shortest digits that read back (as Rust's), written in
/// positional notation when the decimal exponent is in -4..16 and as `d.ddde+XX` otherwise.
pub fn py_repr(x: f64) -> String {
    if x == 0.0 {
        return if x.is_sign_negative() { "-0.0" } else { "0.0" }.into();
    }
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    // `{:e}`: the shortest round-trip digits, `d.ddde<exp>`
    let sci = format!("{:e}", x.abs());
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    let sign = if x < 0.0 { "-" } else { "" };
    if (-4..16).contains(&exp) {
        let point = exp + 1;
        let body = if point <= 0 {
            format!("0.{}{digits}", "0".repeat(-point as usize))
        } else if digits.len() as i32 <= point {
            format!("{digits}{}.0", "0".repeat((point - digits.len() as i32) as usize))
        } else {
            format!("{}.{}", &digits[..point as usize], &digits[point as usize..])
        };
        format!("{sign}{body}")
    } else {
        let rest = if digits.len() > 1 { format!(".{}", &digits[1..]) } else { String::new() };
        format!("{sign}{}{rest}e{}{:02}", &digits[..1], if exp < 0 { '-' } else { '+' }, exp.abs())
    }
}

/// The GLID recipe: the cage file as `glid_<Dir>.mat` (the name the script reads the data
/// folder from) in a scratch folder, `python3 corpus_glid.py` on it, and its OBJ and JSON.
fn glid(entry: &CorpusEntry, source: &Path) -> Result<Vec<Vec<u8>>> {
    let dir_name = entry.path.rsplit('/').nth(1).context("the source path has no data folder")?;
    let scratch = tempdir(source)?;
    let (mat_name, script) = (format!("glid_{dir_name}.mat"), scratch.join("corpus_glid.py"));
    std::fs::copy(source, scratch.join(&mat_name)).with_context(|| format!("{}: cannot copy", source.display()))?;
    std::fs::write(&script, GLID_SCRIPT).with_context(|| format!("{}: cannot write", script.display()))?;
    let out = std::process::Command::new("python3")
        .args([script.as_os_str(), mat_name.as_ref(), "out.obj".as_ref(), "out.p2p.json".as_ref()])
        .current_dir(&scratch)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output();
    let result = match out {
        Err(e) => Err(anyhow::anyhow!("cannot start python3: {e}")),
        Ok(o) if !o.status.success() => {
            let err = String::from_utf8_lossy(&o.stderr);
            Err(anyhow::anyhow!(
                "python3 scripts/corpus_glid.py failed ({}): it needs numpy, scipy and triangle (`python3 -m pip install \
                 numpy scipy triangle`); or install from a copy of the corpus with --from, or leave the GLID shapes out \
                 with --only",
                err.lines().last().unwrap_or("no message")
            ))
        }
        Ok(_) => ["out.obj", "out.p2p.json"]
            .iter()
            .map(|f| std::fs::read(scratch.join(f)).with_context(|| format!("the script wrote no {f}")))
            .collect(),
    };
    let _ = std::fs::remove_dir_all(&scratch);
    result
}

/// A new folder beside `near` (the download folder, inside the target: nothing is written
/// elsewhere).
fn tempdir(near: &Path) -> Result<std::path::PathBuf> {
    let parent = near.parent().unwrap_or(Path::new("."));
    for k in 0..1000 {
        let d = parent.join(format!("glid-{}-{k}", std::process::id()));
        if std::fs::create_dir(&d).is_ok() {
            return Ok(d);
        }
    }
    bail!("{}: cannot make a scratch folder", parent.display())
}
