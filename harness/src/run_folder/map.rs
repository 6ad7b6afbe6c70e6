//! The final map of a run as an OBJ file (`uv/<run>.obj`): the source mesh as `v` (as loaded),
//! the map as `vt`, faces as `f a/a b/b c/c`. Any viewer shows it as a texture, and the report
//! colors each triangle by its distortion from this file alone. Map coordinates are those the
//! solver works in: the area-1 frame for `param` and `deform`, the unit disk for `authalic`.

use anyhow::{bail, Context, Result};
use solvers::mesh::Mesh;
use std::fmt::Write as _;
use std::path::Path;

/// A map read back from its OBJ.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFile {
    pub source: Vec<[f64; 3]>,
    pub uv: Vec<[f64; 2]>,
    pub faces: Vec<[usize; 3]>,
}

/// Serialize `x` (`[u0, v0, u1, v1, ...]`) as the map of `mesh`.
pub fn to_obj(mesh: &Mesh, x: &[f64]) -> Vec<u8> {
    let mut s = format!("# final map: {} vertices, {} faces\n", mesh.n_vertices(), mesh.n_faces());
    for p in &mesh.positions {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]);
    }
    for p in x.chunks_exact(2) {
        let _ = writeln!(s, "vt {:?} {:?}", p[0], p[1]);
    }
    for f in &mesh.faces {
        let (a, b, c) = (f[0] + 1, f[1] + 1, f[2] + 1);
        let _ = writeln!(s, "f {a}/{a} {b}/{b} {c}/{c}");
    }
    s.into_bytes()
}

/// Read a file written by [`to_obj`]; errors name the file and the line.
pub fn read(path: &Path) -> Result<MapFile> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse(&text).with_context(|| format!("{}: not a mapbench map OBJ", path.display()))
}

fn parse(text: &str) -> Result<MapFile> {
    let mut m = MapFile { source: Vec::new(), uv: Vec::new(), faces: Vec::new() };
    for (i, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        let nums = |it: std::str::SplitWhitespace, n: usize| -> Result<Vec<f64>> {
            let v: Vec<f64> =
                it.map(str::parse).collect::<Result<_, _>>().with_context(|| format!("line {}", i + 1))?;
            if v.len() != n {
                bail!("line {}: expected {n} numbers", i + 1);
            }
            Ok(v)
        };
        match it.next() {
            Some("v") => {
                let v = nums(it, 3)?;
                m.source.push([v[0], v[1], v[2]]);
            }
            Some("vt") => {
                let v = nums(it, 2)?;
                m.uv.push([v[0], v[1]]);
            }
            Some("f") => {
                let mut f = [0usize; 3];
                let corners: Vec<&str> = it.collect();
                if corners.len() != 3 {
                    bail!("line {}: a face needs 3 corners", i + 1);
                }
                for (k, c) in corners.iter().enumerate() {
                    let (a, b) = c.split_once('/').with_context(|| format!("line {}: corner without `/`", i + 1))?;
                    let (a, b): (usize, usize) = (a.parse()?, b.parse()?);
                    if a != b || a == 0 {
                        bail!("line {}: corner {c} is not `i/i`", i + 1);
                    }
                    f[k] = a - 1;
                }
                m.faces.push(f);
            }
            _ => {}
        }
    }
    if m.source.len() != m.uv.len() {
        bail!("{} vertices but {} map positions", m.source.len(), m.uv.len());
    }
    if let Some(f) = m.faces.iter().find(|f| f.iter().any(|&v| v >= m.source.len())) {
        bail!("face {f:?} refers past the {} vertices", m.source.len());
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_exactly() {
        let mesh = solvers::generate::generate("bumpy_1k").unwrap();
        let x: Vec<f64> = (0..2 * mesh.n_vertices()).map(|i| (i as f64 * 0.37).sin() / 3.0).collect();
        let m = parse(std::str::from_utf8(&to_obj(&mesh, &x)).unwrap()).unwrap();
        assert_eq!(m.source, mesh.positions);
        assert_eq!(m.faces, mesh.faces);
        assert_eq!(m.uv.iter().flatten().copied().collect::<Vec<_>>(), x);
    }

    #[test]
    fn rejects_what_it_did_not_write() {
        assert!(parse("v 0 0 0\nvt 0 0\nvt 1 1\n").is_err());
        assert!(parse("v 0 0 0\nvt 0 0\nf 1/1 1/2 1/1\n").is_err());
        assert!(parse("v 0 0 0\nvt 0 0\nf 1/1 2/2 1/1\n").is_err());
        assert!(parse("v 0 0 x\nvt 0 0\n").is_err());
    }
}
