//! The final map of a run, stored compactly: the map's UVs alone in `uv/<run>.uv.gz`, next to
//! one copy of the dataset's mesh per run folder in `meshes/<dataset>.obj.gz` (an OBJ with the
//! source mesh as `v` and the faces, gzip-compressed). The report colors each triangle by its
//! distortion from these two files alone; `mapbench map` joins them into the classic OBJ
//! (`v`, `vt`, `f a/a b/b c/c`) any viewer opens. Folders written before the compact format
//! have one `uv/<run>.obj` per run instead, and still read back.
//!
//! `uv/<run>.uv.gz` is gzip over: the magic line `mapbench uv 1\n`, then little-endian `u64`
//! vertex count and `u64` checksum of the mesh (FNV-1a over its positions' `f64` bits and its
//! faces' indices), then the `2n` coordinates `u0 v0 u1 v1 ...` as `f64`, byte-shuffled (every
//! value's byte 0, then every value's byte 1, ...) so that deflate finds the runs in their
//! signs and exponents. Values are exact: the map reads back bit for bit. Map coordinates are
//! those the solver works in: the area-1 frame for `param` and `deform`, the unit disk for
//! `authalic`.

use anyhow::{bail, Context, Result};
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use flate2::Compression;
use solvers::mesh::Mesh;
use std::fmt::Write as _;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

const UV_MAGIC: &[u8] = b"mapbench uv 1\n";

/// A map read back: the source mesh and the map's position of each of its vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFile {
    pub source: Vec<[f64; 3]>,
    pub uv: Vec<[f64; 2]>,
    pub faces: Vec<[usize; 3]>,
}

/// A dataset's mesh as stored beside its maps, with the checksum the maps name.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredMesh {
    pub positions: Vec<[f64; 3]>,
    pub faces: Vec<[usize; 3]>,
    pub checksum: u64,
}

/// `uv/<run>.uv.gz`: the map's UVs.
pub fn uv_path(dir: &Path, stem: &str) -> PathBuf {
    dir.join("uv").join(format!("{stem}.uv.gz"))
}

/// `meshes/<dataset>.obj.gz`: the mesh every map of the dataset refers to.
pub fn mesh_path(dir: &Path, dataset: &str) -> PathBuf {
    dir.join("meshes").join(format!("{dataset}.obj.gz"))
}

/// `uv/<run>.obj`: a map in the format of folders written before the compact one.
pub fn legacy_obj_path(dir: &Path, stem: &str) -> PathBuf {
    dir.join("uv").join(format!("{stem}.obj"))
}

/// FNV-1a over the mesh's positions (their bits) and faces: what ties a map to its mesh.
pub fn checksum(positions: &[[f64; 3]], faces: &[[usize; 3]]) -> u64 {
    let mut h = crate::hash::Fnv::new();
    h.word(positions.len() as u64);
    positions.iter().flatten().for_each(|x| {
        h.word(x.to_bits());
    });
    h.word(faces.len() as u64);
    faces.iter().flatten().for_each(|&v| {
        h.word(v as u64);
    });
    h.0
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = GzEncoder::new(Vec::with_capacity(bytes.len() / 2), Compression::default());
    // Writing into a Vec cannot fail.
    let _ = enc.write_all(bytes);
    enc.finish().unwrap_or_default()
}

fn gunzip(path: &Path) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut out = Vec::new();
    GzDecoder::new(std::io::BufReader::new(file))
        .read_to_end(&mut out)
        .with_context(|| format!("{}: not a complete gzip file", path.display()))?;
    Ok(out)
}

/// `meshes/<dataset>.obj.gz`'s bytes for `mesh`: `v` lines (shortest round-trip `f64`s) and
/// `f` lines, so `zcat` gives an OBJ of the source mesh.
pub fn encode_mesh(mesh: &Mesh) -> Vec<u8> {
    let header = format!(
        "# mapbench mesh: {} vertices, {} faces, checksum {:016x}\n",
        mesh.n_vertices(),
        mesh.n_faces(),
        checksum(&mesh.positions, &mesh.faces)
    );
    gzip((header + &obj_text(mesh)).as_bytes())
}

/// `mesh` as OBJ text: `v` lines with shortest round-trip `f64`s (they read back exactly) and
/// 1-based `f` lines.
pub fn obj_text(mesh: &Mesh) -> String {
    let mut s = String::with_capacity(48 * mesh.n_vertices() + 24 * mesh.n_faces());
    for p in &mesh.positions {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]);
    }
    for f in &mesh.faces {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// `uv/<run>.uv.gz`'s bytes for the map `x` (`[u0, v0, u1, v1, ...]`) of `mesh`.
pub fn encode_uv(mesh: &Mesh, x: &[f64]) -> Vec<u8> {
    let mut raw = Vec::with_capacity(UV_MAGIC.len() + 16 + 8 * x.len());
    raw.extend_from_slice(UV_MAGIC);
    raw.extend_from_slice(&(mesh.n_vertices() as u64).to_le_bytes());
    raw.extend_from_slice(&checksum(&mesh.positions, &mesh.faces).to_le_bytes());
    let bytes: Vec<[u8; 8]> = x.iter().map(|v| v.to_le_bytes()).collect();
    for k in 0..8 {
        raw.extend(bytes.iter().map(|b| b[k]));
    }
    gzip(&raw)
}

/// Read `meshes/<dataset>.obj.gz`; errors name the file and the line.
pub fn read_mesh(path: &Path) -> Result<StoredMesh> {
    let text = String::from_utf8(gunzip(path)?).with_context(|| format!("{}: not UTF-8 text", path.display()))?;
    let m = parse_obj(&text, false).with_context(|| format!("{}: not a mapbench mesh", path.display()))?;
    let checksum = checksum(&m.source, &m.faces);
    Ok(StoredMesh { positions: m.source, faces: m.faces, checksum })
}

/// Read `uv/<run>.uv.gz`, checking that it is a map of `mesh`.
pub fn read_uv(path: &Path, mesh: &StoredMesh) -> Result<Vec<[f64; 2]>> {
    let raw = gunzip(path)?;
    let bad = |what: String| anyhow::anyhow!("{}: {what}", path.display());
    let Some(rest) = raw.strip_prefix(UV_MAGIC) else {
        // `mapbench uv 9`: another version of the format, not a file of something else.
        let version = raw.strip_prefix(b"mapbench uv ".as_slice()).and_then(|r| r.split(|&b| b == b'\n').next());
        return Err(bad(match version {
            Some(v) => format!(
                "map format version `{}`, which this mapbench does not read (it reads version 1)",
                String::from_utf8_lossy(&v[..v.len().min(20)])
            ),
            None => "not a mapbench map (no `mapbench uv 1` header)".into(),
        }));
    };
    if rest.len() < 16 {
        return Err(bad("cut short in its header".into()));
    }
    let word = |i: usize| u64::from_le_bytes(rest[8 * i..8 * i + 8].try_into().unwrap_or_default());
    let (n, sum, data) = (word(0), word(1), &rest[16..]);
    if n != mesh.positions.len() as u64 || sum != mesh.checksum {
        return Err(bad(format!(
            "a map of a mesh with {n} vertices and checksum {sum:016x}, but the stored mesh has {} vertices and \
             checksum {:016x}",
            mesh.positions.len(),
            mesh.checksum
        )));
    }
    let values = 2 * mesh.positions.len();
    if data.len() != 8 * values {
        return Err(bad(format!("{} bytes of coordinates where {values} values take {}", data.len(), 8 * values)));
    }
    let value = |i: usize| f64::from_le_bytes(std::array::from_fn(|k| data[k * values + i]));
    Ok((0..mesh.positions.len()).map(|v| [value(2 * v), value(2 * v + 1)]).collect())
}

/// The stored map of run `stem` on `dataset`, in either format: `Ok(None)` when the folder
/// has none.
pub fn read(dir: &Path, dataset: &str, stem: &str) -> Result<Option<MapFile>> {
    read_with(dir, stem, || read_mesh(&mesh_path(dir, dataset)))
}

/// [`read`] with the dataset's mesh from `mesh` (called only for a compact map), so a caller
/// reading many maps of one dataset reads the mesh once.
pub fn read_with(dir: &Path, stem: &str, mesh: impl FnOnce() -> Result<StoredMesh>) -> Result<Option<MapFile>> {
    let uv = uv_path(dir, stem);
    if uv.exists() {
        let mesh = mesh()?;
        let uv = read_uv(&uv, &mesh)?;
        return Ok(Some(MapFile { source: mesh.positions, uv, faces: mesh.faces }));
    }
    let obj = legacy_obj_path(dir, stem);
    if obj.exists() {
        return read_obj(&obj).map(Some);
    }
    Ok(None)
}

/// Read a map as text, one `u v` line per vertex (the external solvers' `.uv`: any language
/// writes and reads it, and a shortest round-trip decimal is the exact `f64`); it must have
/// `n` lines. Errors name the file and the line.
pub fn read_uv_text(path: &Path, n: usize) -> Result<Vec<[f64; 2]>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut uv = Vec::with_capacity(n);
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .with_context(|| format!("{}: line {}: not numbers", path.display(), i + 1))?;
        let [u, w] = v[..] else {
            bail!("{}: line {}: expected `u v`, found {} numbers", path.display(), i + 1, v.len())
        };
        uv.push([u, w]);
    }
    if uv.len() != n {
        bail!("{}: {} map vertices, but the mesh has {n}", path.display(), uv.len());
    }
    Ok(uv)
}

/// `read_uv_text`'s format: `u v` per vertex, shortest round-trip decimals.
pub fn uv_text(uv: &[[f64; 2]]) -> String {
    uv.iter().map(|p| format!("{:?} {:?}\n", p[0], p[1])).collect()
}

/// The classic OBJ of a map: the source mesh as `v`, the map as `vt`, faces `f a/a b/b c/c`.
pub fn to_obj(map: &MapFile) -> Vec<u8> {
    let mut s = format!("# final map: {} vertices, {} faces\n", map.source.len(), map.faces.len());
    for p in &map.source {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]);
    }
    for p in &map.uv {
        let _ = writeln!(s, "vt {:?} {:?}", p[0], p[1]);
    }
    for f in &map.faces {
        let (a, b, c) = (f[0] + 1, f[1] + 1, f[2] + 1);
        let _ = writeln!(s, "f {a}/{a} {b}/{b} {c}/{c}");
    }
    s.into_bytes()
}

/// Read a map OBJ written by [`to_obj`] (the legacy `uv/<run>.obj`); errors name the file and
/// the line.
pub fn read_obj(path: &Path) -> Result<MapFile> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse_obj(&text, true).with_context(|| format!("{}: not a mapbench map OBJ", path.display()))
}

/// Parse `v`, `vt` and `f` lines: with `with_uv` faces are `i/i` and every vertex has a `vt`,
/// without, faces are plain indices and there is no `vt`.
fn parse_obj(text: &str, with_uv: bool) -> Result<MapFile> {
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
            Some("vt") if with_uv => {
                let v = nums(it, 2)?;
                m.uv.push([v[0], v[1]]);
            }
            Some("vt") => bail!("line {}: a mesh file has no `vt`", i + 1),
            Some("f") => {
                let mut f = [0usize; 3];
                let corners: Vec<&str> = it.collect();
                if corners.len() != 3 {
                    bail!("line {}: a face needs 3 corners", i + 1);
                }
                for (k, c) in corners.iter().enumerate() {
                    let a: usize = if with_uv {
                        let (a, b) =
                            c.split_once('/').with_context(|| format!("line {}: corner without `/`", i + 1))?;
                        let (a, b): (usize, usize) = (a.parse()?, b.parse()?);
                        if a != b {
                            bail!("line {}: corner {c} is not `i/i`", i + 1);
                        }
                        a
                    } else {
                        c.parse().with_context(|| format!("line {}: corner {c} is not an index", i + 1))?
                    };
                    if a == 0 {
                        bail!("line {}: corner {c}: OBJ indices start at 1", i + 1);
                    }
                    f[k] = a - 1;
                }
                m.faces.push(f);
            }
            _ => {}
        }
    }
    if with_uv && m.source.len() != m.uv.len() {
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
    fn a_text_map_reads_back_bit_for_bit_and_names_a_bad_line() {
        let (mesh, x) = bumpy();
        let uv: Vec<[f64; 2]> = x.chunks(2).map(|c| [c[0], c[1]]).collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.uv");
        std::fs::write(&path, uv_text(&uv)).unwrap();
        assert_eq!(read_uv_text(&path, mesh.n_vertices()).unwrap(), uv);
        let err = read_uv_text(&path, mesh.n_vertices() + 1).unwrap_err().to_string();
        assert!(err.ends_with(&format!("{} map vertices, but the mesh has {}", uv.len(), uv.len() + 1)), "{err}");
        std::fs::write(&path, "1 2\n3\n").unwrap();
        assert!(read_uv_text(&path, 2).unwrap_err().to_string().ends_with("line 2: expected `u v`, found 1 numbers"));
        std::fs::write(&path, "1 2\n3 x\n").unwrap();
        assert!(format!("{:#}", read_uv_text(&path, 2).unwrap_err()).contains("line 2: not numbers"));
    }

    fn bumpy() -> (Mesh, Vec<f64>) {
        let mesh = solvers::generate::generate("bumpy_1k").unwrap();
        // Values of every magnitude and sign, including ones without a short decimal form.
        let x: Vec<f64> =
            (0..2 * mesh.n_vertices()).map(|i| (i as f64 * 0.37).sin() / 3.0 * 10f64.powi(i as i32 % 7 - 3)).collect();
        (mesh, x)
    }

    fn write(path: &Path, bytes: &[u8]) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn the_compact_format_round_trips_exactly() {
        let (mesh, x) = bumpy();
        let dir = tempfile::tempdir().unwrap();
        write(&mesh_path(dir.path(), "bumpy_1k"), &encode_mesh(&mesh));
        write(&uv_path(dir.path(), "bumpy_1k__sd__cm"), &encode_uv(&mesh, &x));
        let m = read(dir.path(), "bumpy_1k", "bumpy_1k__sd__cm").unwrap().unwrap();
        assert_eq!(m.source, mesh.positions);
        assert_eq!(m.faces, mesh.faces);
        let back: Vec<f64> = m.uv.iter().flatten().copied().collect();
        assert!(back.iter().zip(&x).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(back.len(), x.len());
        // No map stored: none, not an error.
        assert_eq!(read(dir.path(), "bumpy_1k", "bumpy_1k__sd__slim").unwrap(), None);
        // The UVs are a fraction of the classic OBJ.
        let (uv, obj) = (encode_uv(&mesh, &x).len(), to_obj(&m).len());
        assert!(uv * 3 < obj, "{uv} vs {obj}");
    }

    #[test]
    fn a_map_of_another_mesh_is_refused() {
        let (mesh, x) = bumpy();
        let dir = tempfile::tempdir().unwrap();
        let mut other = mesh.clone();
        other.positions[3][2] += 1e-9;
        write(&mesh_path(dir.path(), "d"), &encode_mesh(&other));
        write(&uv_path(dir.path(), "d__sd__cm"), &encode_uv(&mesh, &x));
        let e = format!("{:#}", read(dir.path(), "d", "d__sd__cm").unwrap_err());
        assert!(e.contains("d__sd__cm.uv.gz") && e.contains("checksum"), "{e}");
        // A cut file names itself.
        let bytes = encode_uv(&other, &x);
        write(&uv_path(dir.path(), "d__sd__cm"), &bytes[..bytes.len() / 2]);
        let e = format!("{:#}", read(dir.path(), "d", "d__sd__cm").unwrap_err());
        assert!(e.contains("d__sd__cm.uv.gz"), "{e}");
        // Another version of the format says so (it read as "no `mapbench uv 1` header").
        write(&uv_path(dir.path(), "d__sd__cm"), &gzip(&[b"mapbench uv 9\n".as_slice(), &[0; 16]].concat()));
        let e = format!("{:#}", read(dir.path(), "d", "d__sd__cm").unwrap_err());
        assert!(e.contains("map format version `9`, which this mapbench does not read"), "{e}");
        write(&uv_path(dir.path(), "d__sd__cm"), &gzip(b"P6\n"));
        let e = format!("{:#}", read(dir.path(), "d", "d__sd__cm").unwrap_err());
        assert!(e.contains("not a mapbench map (no `mapbench uv 1` header)"), "{e}");
        // The mesh missing, too.
        std::fs::remove_file(mesh_path(dir.path(), "d")).unwrap();
        let e = format!("{:#}", read(dir.path(), "d", "d__sd__cm").unwrap_err());
        assert!(e.contains("d.obj.gz"), "{e}");
    }

    #[test]
    fn legacy_obj_maps_still_read() {
        let (mesh, x) = bumpy();
        let dir = tempfile::tempdir().unwrap();
        let map = MapFile {
            source: mesh.positions.clone(),
            uv: x.chunks_exact(2).map(|p| [p[0], p[1]]).collect(),
            faces: mesh.faces.clone(),
        };
        write(&legacy_obj_path(dir.path(), "d__sd__cm"), &to_obj(&map));
        assert_eq!(read(dir.path(), "d", "d__sd__cm").unwrap(), Some(map));
    }

    #[test]
    fn rejects_what_it_did_not_write() {
        assert!(parse_obj("v 0 0 0\nvt 0 0\nvt 1 1\n", true).is_err());
        assert!(parse_obj("v 0 0 0\nvt 0 0\nf 1/1 1/2 1/1\n", true).is_err());
        assert!(parse_obj("v 0 0 0\nvt 0 0\nf 1/1 2/2 1/1\n", true).is_err());
        assert!(parse_obj("v 0 0 x\nvt 0 0\n", true).is_err());
        assert!(parse_obj("v 0 0 0\nvt 0 0\n", false).is_err());
        assert!(parse_obj("v 0 0 0\nf 1 1 0\n", false).is_err());
    }
}
