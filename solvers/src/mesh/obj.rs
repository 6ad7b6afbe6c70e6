//! Wavefront OBJ input: `v` and triangle `f` lines.
//!
//! This is a small parser of its own rather than `tobj`, because `tobj` renumbers vertices
//! (in order of first use, per object/group/material), which (1) breaks the file's vertex
//! numbering that handle/P2P files refer to, (2) silently drops unreferenced vertices, which
//! validation must report, and (3) duplicates the vertices shared by two `g`/`o`/`usemtl`
//! blocks, cutting the surface apart. Here OBJ indices are global over the file, as the format
//! says, so all objects and groups form one mesh with the file's vertex order.
//! Everything except `v` and `f` (texture coordinates, normals, groups, materials, lines,
//! unknown statements, comments) is ignored. A UTF-8 byte-order mark is skipped, and lines may
//! end in `\n`, `\r\n` or a lone `\r` (classic Mac OS exports).

use super::error::MeshError;
use super::triangle_mesh::Mesh;
use std::path::Path;

/// Read a triangle mesh from an OBJ file. The mesh's `source` is the path as displayed.
///
/// Unreadable files give [`MeshError::Io`]; anything else wrong with the text (non-triangle
/// faces, bad numbers, out-of-range indices, non-finite coordinates, no vertices or faces)
/// gives [`MeshError::Malformed`] naming the line. Topology is not checked here: run
/// [`validate`](super::validate()).
pub fn load_obj(path: &Path) -> Result<Mesh, MeshError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| MeshError::Io { path: source.clone(), source: e })?;
    parse_obj(&source, &bytes)
}

/// Parse OBJ text held in memory; `source` names it in the mesh and in every message.
pub fn parse_obj(source: &str, bytes: &[u8]) -> Result<Mesh, MeshError> {
    let bad = |message: String| MeshError::Malformed { path: source.to_string(), message };
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<[usize; 3]> = Vec::new();
    // 1-based positive indices, resolved once the vertex count is known (forward references
    // are tolerated), with the line of each face for messages.
    let mut raw: Vec<([i64; 3], usize)> = Vec::new();
    // Windows editors write a BOM; left in, it would glue onto the first keyword ("\u{feff}v")
    // and that vertex would be ignored, shifting every index after it.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    for (l, line) in lines(bytes).enumerate() {
        let lineno = l + 1;
        let line =
            std::str::from_utf8(line).map_err(|_| bad(format!("line {lineno} is not UTF-8 text (binary file?)")))?;
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => positions.push(vertex(words, lineno, positions.len()).map_err(bad)?),
            Some("f") => raw.push((face(words, lineno, raw.len(), positions.len()).map_err(bad)?, lineno)),
            _ => {}
        }
    }
    let n = positions.len();
    match (n, raw.len()) {
        (0, 0) => return Err(bad("no vertices ('v' lines) and no faces ('f' lines): is this an OBJ file?".into())),
        (0, _) => return Err(bad("no vertices ('v' lines)".into())),
        (_, 0) => return Err(bad("no faces ('f' lines)".into())),
        _ => {}
    }
    faces.reserve(raw.len());
    for (face, (idx, lineno)) in raw.into_iter().enumerate() {
        if let Some(&i) = idx.iter().find(|&&i| i as u64 > n as u64) {
            return Err(bad(format!(
                "line {lineno}: face {face} refers to vertex {i}, but the file has only {n} vertices"
            )));
        }
        faces.push(idx.map(|i| (i - 1) as usize));
    }
    Ok(Mesh::new(source, positions, faces))
}

/// The position of vertex `vertex` from the words after `v` on line `lineno`; extra values
/// (w, vertex colours) do not change the position we use.
fn vertex<'a>(mut words: impl Iterator<Item = &'a str>, lineno: usize, vertex: usize) -> Result<[f64; 3], String> {
    let mut p = [0.0; 3];
    for (k, c) in p.iter_mut().enumerate() {
        let w =
            words.next().ok_or_else(|| format!("line {lineno}: vertex {vertex} has {k} coordinates; 3 are needed"))?;
        *c = w.parse::<f64>().map_err(|_| format!("line {lineno}: vertex {vertex}: cannot read coordinate {w:?}"))?;
    }
    if p.iter().any(|c| !c.is_finite()) {
        return Err(format!("line {lineno}: vertex {vertex} has a non-finite coordinate"));
    }
    Ok(p)
}

/// The 1-based positive vertex indices of triangle `face` from the words after `f` on line
/// `lineno`, `defined` vertices being defined so far (relative indices count back from there).
fn face<'a>(
    words: impl Iterator<Item = &'a str>,
    lineno: usize,
    face: usize,
    defined: usize,
) -> Result<[i64; 3], String> {
    let words: Vec<&str> = words.collect();
    if words.len() != 3 {
        return Err(format!("line {lineno}: face {face} has {} vertices; only triangles are supported", words.len()));
    }
    let mut idx = [0i64; 3];
    for (slot, w) in idx.iter_mut().zip(&words) {
        // `v`, `v/vt`, `v//vn` or `v/vt/vn`: only the position index matters.
        let v = w.split('/').next().unwrap_or("");
        let i: i64 = v.parse().map_err(|_| format!("line {lineno}: face {face}: cannot read vertex index {w:?}"))?;
        *slot = match i {
            0 => return Err(format!("line {lineno}: face {face}: vertex index 0 (OBJ counts from 1)")),
            // Relative: -1 is the last vertex defined so far.
            i if i < 0 => defined as i64 + i + 1,
            i => i,
        };
        if *slot < 1 {
            return Err(format!("line {lineno}: face {face}: relative index {i} is before the first vertex"));
        }
    }
    Ok(idx)
}

/// The lines of `bytes`, ended by `\n`, `\r\n` or a lone `\r`, so that line numbers match
/// what an editor shows for any of the three conventions.
fn lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = Some(bytes);
    std::iter::from_fn(move || {
        let text = rest?;
        match text.iter().position(|&b| b == b'\n' || b == b'\r') {
            Some(i) => {
                let skip = if text[i] == b'\r' && text.get(i + 1) == Some(&b'\n') { 2 } else { 1 };
                rest = Some(&text[i + skip..]);
                Some(&text[..i])
            }
            None => {
                rest = None;
                Some(text)
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::validate;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A file in the temp dir, unique per process and call, removed on drop.
    struct TempObj(PathBuf);

    impl TempObj {
        fn new(text: &[u8]) -> Self {
            static COUNTER: AtomicUsize = AtomicUsize::new(0);
            let k = COUNTER.fetch_add(1, Ordering::Relaxed);
            let path = std::env::temp_dir().join(format!("mapbench_obj_test_{}_{k}.obj", std::process::id()));
            std::fs::write(&path, text).expect("write temp OBJ");
            TempObj(path)
        }
    }

    impl Drop for TempObj {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn load(text: &str) -> (Result<Mesh, MeshError>, String) {
        let f = TempObj::new(text.as_bytes());
        (load_obj(&f.0), f.0.display().to_string())
    }

    fn malformed(text: &str) -> String {
        match load(text) {
            (Err(e @ MeshError::Malformed { .. }), path) => {
                let msg = e.to_string();
                assert!(msg.starts_with(&format!("{path}: malformed OBJ: ")), "{msg}");
                msg
            }
            (other, _) => panic!("expected Malformed, got {other:?}"),
        }
    }

    const SQUARE: &str = "# unit square\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

    #[test]
    fn two_triangles() {
        let (m, path) = load(SQUARE);
        let m = m.expect("valid OBJ");
        assert_eq!(m.source, path);
        assert_eq!(m.positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(validate(&m, true).is_ok());
    }

    #[test]
    fn tolerated_syntax() {
        // CRLF, comments, v/vt/vn, relative indices, groups, extra vertex values, unknown statements
        let text = "mtllib x.mtl\r\nv 0 0 0 1\r\nv 1 0 0 0.5 0.5 0.5\r\nv 1 1 0 # c\r\nvt 0 0\r\nvn 0 0 1\r\n\
                    g a\r\nusemtl m\r\nf 1/1/1 2/1/1 3/1/1\r\nv 0 1 0\r\ng b\r\ns off\r\nf -4//1 -2//1 -1//1\r\n\
                    l 1 2\r\nfoo bar\r\n\r\n   \r\n";
        let m = load(text).0.expect("valid OBJ");
        assert_eq!(m.n_vertices(), 4);
        // groups do not split shared vertices: one connected disk
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(validate(&m, true).is_ok());
    }

    #[test]
    fn byte_order_mark_is_skipped() {
        let text = format!("\u{feff}{SQUARE}");
        let m = load(&text).0.expect("a BOM before the first line is not part of it");
        assert_eq!(m.n_vertices(), 4);
        assert_eq!(m.positions[0], [0.0, 0.0, 0.0]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        // a BOM before a `v` line: the vertex counts, so later indices stay right
        let m = load("\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").0.expect("valid OBJ");
        assert_eq!((m.n_vertices(), m.faces.clone()), (3, vec![[0, 1, 2]]));
    }

    #[test]
    fn cr_only_line_endings() {
        let m = load(&SQUARE.replace('\n', "\r")).0.expect("lone CR ends a line");
        assert_eq!(m.n_vertices(), 4);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        // line numbers count CR, CRLF and LF line ends alike
        let msg = malformed("v 0 0 0\rv 1 0 0\r\nv 0 1 0\nf 1 2 x\r");
        assert!(msg.ends_with("line 4: face 0: cannot read vertex index \"x\""), "{msg}");
        let msg = malformed("v 0 0 0\r\rv 1 0\r");
        assert!(msg.ends_with("line 3: vertex 1 has 2 coordinates; 3 are needed"), "{msg}");
    }

    #[test]
    fn vertex_order_and_unreferenced_vertices_are_kept() {
        // tobj would renumber (vertex 2 first) and drop vertex 3
        let m = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\nf 3 1 2\n").0.expect("valid OBJ");
        assert_eq!(m.positions[3], [9.0, 9.0, 9.0]);
        assert_eq!(m.faces, vec![[2, 0, 1]]);
        assert_eq!(
            validate(&m, false).problems,
            vec![crate::mesh::Defect::UnreferencedVertices { count: 1, first: 3 }]
        );
    }

    #[test]
    fn quad_rejected() {
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 2 3 4\n");
        assert!(msg.ends_with("line 6: face 1 has 4 vertices; only triangles are supported"), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0 0\nf 1 2\n");
        assert!(msg.ends_with("line 3: face 0 has 2 vertices; only triangles are supported"), "{msg}");
    }

    #[test]
    fn missing_file_is_io() {
        let p = std::env::temp_dir().join(format!("mapbench_no_such_file_{}.obj", std::process::id()));
        match load_obj(&p) {
            Err(e @ MeshError::Io { .. }) => {
                assert!(e.to_string().starts_with(&format!("{}: cannot read file: ", p.display())), "{e}")
            }
            other => panic!("expected Io, got {other:?}"),
        }
        // a directory is unreadable as a file, too
        assert!(matches!(load_obj(&std::env::temp_dir()), Err(MeshError::Io { .. })));
    }

    #[test]
    fn garbage() {
        let msg = malformed("hello world\nthis is not an OBJ file\n");
        assert!(msg.ends_with("no vertices ('v' lines) and no faces ('f' lines): is this an OBJ file?"), "{msg}");
        let f = TempObj::new(&[0x7f, b'E', b'L', b'F', 0xff, 0xfe, 0, 1, 2, b'\n']);
        let msg = load_obj(&f.0).unwrap_err().to_string();
        assert!(msg.ends_with("line 1 is not UTF-8 text (binary file?)"), "{msg}");
        let msg = malformed("v 0 0 zero\n");
        assert!(msg.ends_with("line 1: vertex 0: cannot read coordinate \"zero\""), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0\n");
        assert!(msg.ends_with("line 2: vertex 1 has 2 coordinates; 3 are needed"), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
        assert!(msg.ends_with("line 4: face 0: cannot read vertex index \"x\""), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n");
        assert!(msg.contains("cannot read vertex index"), "{msg}");
        // a file cut off in the middle of a face line
        let msg = malformed(&SQUARE[..SQUARE.len() - 3]);
        assert!(msg.ends_with("line 7: face 1 has 2 vertices; only triangles are supported"), "{msg}");
    }

    #[test]
    fn out_of_range_index() {
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
        assert!(msg.ends_with("line 4: face 0 refers to vertex 4, but the file has only 3 vertices"), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
        assert!(msg.ends_with("line 4: face 0: vertex index 0 (OBJ counts from 1)"), "{msg}");
        let msg = malformed("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
        assert!(msg.ends_with("line 4: face 0: relative index -4 is before the first vertex"), "{msg}");
    }

    #[test]
    fn no_faces_or_vertices() {
        assert!(malformed("v 0 0 0\nv 1 0 0\n").ends_with("no faces ('f' lines)"));
        assert!(malformed("f 1 2 3\n").ends_with("no vertices ('v' lines)"));
        assert!(malformed("").contains("is this an OBJ file?"));
    }

    #[test]
    fn non_finite_coordinate() {
        let msg = malformed("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
        assert!(msg.ends_with("line 2: vertex 1 has a non-finite coordinate"), "{msg}");
        assert!(malformed("v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").contains("non-finite"));
    }

    /// The same triangles (by position) as tobj reads them; tobj renumbers vertices, so
    /// compare the corner positions face by face.
    fn same_geometry_as_tobj(path: &Path, mesh: &Mesh) -> Result<(), String> {
        let opts = tobj::LoadOptions { triangulate: false, single_index: true, ..Default::default() };
        let (models, _) = tobj::load_obj(path, &opts).map_err(|e| e.to_string())?;
        let mut k = 0;
        for model in &models {
            let (p, idx) = (&model.mesh.positions, &model.mesh.indices);
            if !model.mesh.face_arities.is_empty() {
                return Err("tobj found non-triangle faces".into());
            }
            for t in idx.chunks(3) {
                let f = mesh.faces.get(k).ok_or("tobj has more faces")?;
                for c in 0..3 {
                    let i = t[c] as usize;
                    if p[3 * i..3 * i + 3] != mesh.positions[f[c]][..] {
                        return Err(format!("face {k} corner {c} differs"));
                    }
                }
                k += 1;
            }
        }
        if k == mesh.n_faces() {
            Ok(())
        } else {
            Err(format!("tobj has {k} faces, we have {}", mesh.n_faces()))
        }
    }

    #[test]
    fn agrees_with_tobj_on_a_small_file() {
        let f = TempObj::new(SQUARE.as_bytes());
        let m = load_obj(&f.0).expect("valid OBJ");
        same_geometry_as_tobj(&f.0, &m).expect("same geometry");
    }

    /// Manifest counts of one shared mesh: vertices, faces, boundary loops, Euler, disk.
    fn manifest(dir: &Path) -> Vec<(String, [i64; 4], bool)> {
        let Ok(text) = std::fs::read_to_string(dir.join("MANIFEST.toml")) else { return Vec::new() };
        let field = |block: &str, key: &str| -> Option<String> {
            block.lines().find_map(|l| {
                let (k, v) = l.split_once('=')?;
                (k.trim() == key).then(|| v.trim().trim_matches('"').to_string())
            })
        };
        text.split("[[mesh]]")
            .skip(1)
            .filter_map(|b| {
                let num = |k: &str| field(b, k).and_then(|v| v.parse::<i64>().ok());
                Some((
                    field(b, "file")?,
                    [num("vertices")?, num("faces")?, num("boundary_loops")?, num("euler_characteristic")?],
                    field(b, "topological_disk")? == "yes",
                ))
            })
            .collect()
    }

    /// Load and validate every OBJ of `$MAPBENCH_MESHES` (the shared corpus); check the counts
    /// against its MANIFEST.toml when present and the geometry against tobj.
    #[test]
    fn shared_corpus_loads_and_validates() {
        let Ok(dir) = std::env::var("MAPBENCH_MESHES") else {
            eprintln!("MAPBENCH_MESHES not set: shared-corpus test skipped");
            return;
        };
        let dir = PathBuf::from(dir);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .expect("MAPBENCH_MESHES is a readable directory")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "obj"))
            .collect();
        files.sort();
        let manifest = manifest(&dir);
        let mut failures = Vec::new();
        for path in &files {
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let t = std::time::Instant::now();
            let mesh = match load_obj(path) {
                Ok(m) => m,
                Err(e) => {
                    failures.push(format!("{name}: {e}"));
                    continue;
                }
            };
            let t_load = t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let r = validate(&mesh, true);
            let t_val = t.elapsed().as_secs_f64();
            let kind = if mesh.is_planar() { "2D" } else { "3D" };
            let verdict = if r.is_ok() { "disk".to_string() } else { format!("NOT a disk: {}", summarize(&r)) };
            eprintln!(
                "{name:22} {kind} V={:7} F={:7} E={:7} loops={} euler={} comps={}  load {t_load:.2}s validate {t_val:.2}s  {verdict}",
                r.n_vertices, r.n_faces, r.n_edges, r.boundary_loops, r.euler, r.components
            );
            if !r.is_ok() {
                let open = validate(&mesh, false);
                eprintln!(
                    "{:22} without require_disk: {}",
                    "",
                    if open.is_ok() { "valid".into() } else { summarize(&open) }
                );
            }
            if mesh.is_planar() {
                // the outer loop of a counter-clockwise 2D shape runs counter-clockwise, holes clockwise
                let area = |l: &[usize]| -> f64 {
                    let p = |k: usize| mesh.positions[l[k % l.len()]];
                    (0..l.len()).map(|k| p(k)[0] * p(k + 1)[1] - p(k)[1] * p(k + 1)[0]).sum::<f64>() / 2.0
                };
                let areas: Vec<f64> = crate::mesh::topology::boundary_loops(&mesh.faces, mesh.n_vertices())
                    .iter()
                    .map(|l| area(l))
                    .collect();
                let outer = areas.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                if outer <= 0.0 || areas.iter().filter(|&&a| a > 0.0).count() != 1 {
                    failures.push(format!("{name}: boundary loop signed areas {areas:?}"));
                }
            }
            if let Some((_, counts, disk)) = manifest.iter().find(|(f, _, _)| *f == name) {
                let ours = [r.n_vertices as i64, r.n_faces as i64, r.boundary_loops as i64, r.euler];
                if ours != *counts {
                    failures.push(format!("{name}: counts {ours:?} but the manifest says {counts:?}"));
                }
                if *disk != r.is_ok() {
                    failures.push(format!("{name}: manifest disk = {disk}, validation: {r}"));
                }
            }
            if let Err(e) = same_geometry_as_tobj(path, &mesh) {
                failures.push(format!("{name}: differs from tobj: {e}"));
            }
        }
        eprintln!("{} meshes checked", files.len());
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    fn summarize(r: &crate::mesh::ValidationReport) -> String {
        crate::mesh::defect::summarize_problems(&r.problems, 3, "; ")
    }
}
