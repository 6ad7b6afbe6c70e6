use super::recipe::{obj, parse_obj, py_repr, subdivide, Obj};
use super::*;

#[test]
fn floats_are_written_as_pythons_repr_writes_them() {
    // Python 3.11's repr of each value
    let cases = [
        (f64::from_bits(0x0000000000000000), "0.0"),
        (f64::from_bits(0x8000000000000000), "-0.0"),
        (f64::from_bits(0x3ff0000000000000), "1.0"),
        (f64::from_bits(0xc029be0ded288ce7), "-12.8712"),
        (f64::from_bits(0x3f03660e51d25aab), "3.7e-05"),
        (f64::from_bits(0x3f1a36e2eb1c432d), "0.0001"),
        (f64::from_bits(0x3ee4f8b588e368f1), "1e-05"),
        (f64::from_bits(0x3e8421f5f40d8376), "1.5e-07"),
        (f64::from_bits(0x4341c37937e08000), "1e+16"),
        (f64::from_bits(0x434aa535d3d0c000), "1.5e+16"),
        (f64::from_bits(0x43118b54f22aeb00), "1234567890123456.0"),
        (f64::from_bits(0x4345ee2a2eb5a5c4), "1.2345678901234568e+16"),
        (f64::from_bits(0x3fd3333333333334), "0.30000000000000004"),
        (f64::from_bits(0x3fd5555555555555), "0.3333333333333333"),
        (f64::from_bits(0x0000000000000001), "5e-324"),
        (f64::from_bits(0x7fefffffffffffff), "1.7976931348623157e+308"),
        (f64::from_bits(0x40fe240c9fbe76c9), "123456.789"),
        (f64::from_bits(0xbf201f31f46ed246), "-0.000123"),
        (f64::from_bits(0x4059000000000000), "100.0"),
        (f64::from_bits(0x4480f0cf064dd592), "1e+22"),
        (f64::from_bits(0x4164d8399f767c45), "10928588.983213553"),
        (f64::from_bits(0x5bc8fbbcbde5c099), "1.4186613525849614e+134"),
        (f64::from_bits(0xb0c11fdecb91ce37), "-7.571968556055867e-74"),
        (f64::from_bits(0xa6eb8c9ebd69fe29), "-3.3339745473042614e-121"),
        (f64::from_bits(0xc12cbf4b163cd1f2), "-941989.5434327705"),
        (f64::from_bits(0x3fac421698dffdc4), "0.055191713487143385"),
        (f64::from_bits(0x3f3386c1aad5646b), "0.00029794910627384843"),
        (f64::from_bits(0x40bcc8e8be886e9b), "7368.909157301906"),
    ];
    for (x, want) in cases {
        assert_eq!(py_repr(x), want, "{x:e}");
        assert_eq!(want.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{want} reads back");
    }
}

#[test]
fn an_obj_keeps_its_vertices_and_triangles_in_order_and_nothing_else() {
    let src =
        b"# made by a tool\r\nmtllib x.mtl\nv 1 2.50 -0.0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\nv 1e-5 3 4\nv 0.1 0.2 0.3\n\
                usemtl a\nf 1/1/1 2//2 3\ns off\n";
    let mesh = parse_obj(src).unwrap();
    assert_eq!(mesh.f, [[1, 2, 3]]);
    let out = String::from_utf8(obj("# x: from here\n", &mesh)).unwrap();
    assert_eq!(out, "# x: from here\nv 1.0 2.5 -0.0\nv 1e-05 3.0 4.0\nv 0.1 0.2 0.3\nf 1 2 3\n");
    for bad in [&b"f 1 2 3 4\n"[..], b"v 1 2\n", b"f 0 1 2\n", b"v 1 x 2\n"] {
        assert!(parse_obj(bad).is_err(), "{}", String::from_utf8_lossy(bad));
    }
}

#[test]
fn a_subdivision_puts_the_midpoints_in_sorted_edge_order_and_the_faces_by_corner() {
    // two triangles sharing the edge 2-3
    let v = vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [2.0, 2.0, 1.0]];
    let Obj { v: v2, f: f2 } = subdivide(&Obj { v: v.clone(), f: vec![[1, 2, 3], [2, 4, 3]] }).unwrap();
    // edges (1,2) (1,3) (2,3) (2,4) (3,4) -> 5 6 7 8 9
    assert_eq!(&v2[4..], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 1.0, 0.5], [1.0, 2.0, 0.5]]);
    assert_eq!(f2, [[1, 5, 6], [2, 8, 7], [5, 2, 7], [8, 4, 9], [6, 7, 3], [7, 9, 3], [5, 7, 6], [8, 9, 7]]);
    assert!(subdivide(&Obj { v, f: vec![[1, 2, 5]] }).is_err());
}

/// A MAT-file with `v` (2x3 doubles) and `f` (1x3 uint16), the second compressed if `zip`.
fn mat_file(zip: bool) -> Vec<u8> {
    fn element(kind: u32, data: &[u8]) -> Vec<u8> {
        let mut e = [kind.to_le_bytes(), (data.len() as u32).to_le_bytes()].concat();
        e.extend_from_slice(data);
        e.resize(e.len().div_ceil(8) * 8, 0);
        e
    }
    fn matrix(name: &str, class: u8, rows: i32, cols: i32, kind: u32, data: &[u8]) -> Vec<u8> {
        let mut body = element(6, &[class, 0, 0, 0, 0, 0, 0, 0]);
        body.extend(element(5, &[rows.to_le_bytes(), cols.to_le_bytes()].concat()));
        // the name in the small format: size in the upper half of the tag
        let mut small = [0u8; 8];
        small[..4].copy_from_slice(&(1u32 | ((name.len() as u32) << 16)).to_le_bytes());
        small[4..4 + name.len()].copy_from_slice(name.as_bytes());
        body.extend(small);
        body.extend(element(kind, data));
        element(14, &body)
    }
    let mut out = b"MATLAB 5.0 MAT-file, made by a test".to_vec();
    out.resize(124, b' ');
    out.extend([0x00, 0x01, b'I', b'M']);
    let v: Vec<u8> = [1.0f64, 4.0, 2.0, 5.0, 3.0, 6.5].iter().flat_map(|x| x.to_le_bytes()).collect();
    out.extend(matrix("v", 6, 2, 3, 9, &v));
    let f = matrix("f", 11, 1, 3, 4, &[1, 0, 2, 0, 3, 0]);
    if zip {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&f).unwrap();
        let z = z.finish().unwrap();
        out.extend([15u32.to_le_bytes(), (z.len() as u32).to_le_bytes()].concat());
        out.extend(z);
    } else {
        out.extend(f);
    }
    out
}

#[test]
fn a_mat_files_numeric_matrices_are_read_column_major_compressed_or_not() {
    for zip in [false, true] {
        let m = mat::read(&mat_file(zip)).unwrap();
        let v = &m["v"];
        assert_eq!((v.rows, v.cols), (2, 3));
        assert_eq!([v.at(0, 0), v.at(0, 1), v.at(0, 2), v.at(1, 2)], [1.0, 2.0, 3.0, 6.5]);
        assert_eq!(m["f"].data, [1.0, 2.0, 3.0], "zip {zip}");
    }
    assert!(mat::read(b"not a mat file").is_err());
}

fn entry(name: &str, file: &str, text: &[u8]) -> String {
    format!(
        "[[mesh]]\nname = \"{name}\"\nfile = \"{file}\"\nrecipe = \"obj\"\nbytes = {}\nsha256 = \"{}\"\n\
         repository = \"o/r\"\ncommit = \"c\"\npath = \"{file}\"\nsource_bytes = 1\nsource_sha256 = \"{}\"\n\
         license = \"test\"\n",
        text.len(),
        sha256_hex(text),
        sha256_hex(b"s")
    )
}

#[test]
fn the_built_in_manifest_parses_and_bad_ones_are_refused_naming_the_mesh() {
    let m = Manifest::built_in().unwrap();
    assert_eq!(m.meshes.len(), 30);
    // aphrodite_sub4 brings aphrodite along
    let names: Vec<&str> = m.select(&["*_sub4".into()]).unwrap().iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["aphrodite", "aphrodite_sub4"]);
    assert!(m.select(&["nothing".into()]).is_err());
    let good = entry("a", "a.obj", b"x");
    let p = Path::new("c.toml");
    assert!(Manifest::parse(&format!("version = 1\n{good}"), p).is_ok());
    for (bad, says) in [
        (format!("version = 2\n{good}"), "version 2"),
        (format!("version = 1\n{}", good.replace("sha256 = \"", "sha256 = \"z")), "not a SHA-256"),
        (format!("version = 1\n{good}{good}"), "installed twice"),
        (format!("version = 1\n{}", good.replace("\"obj\"", "\"subdivide\"")), "needs `of`"),
        (format!("version = 1\n{}", good.replace("a.obj", "../a.obj")), "mesh \"a\""),
    ] {
        let e = format!("{:#}", Manifest::parse(&bad, p).unwrap_err());
        assert!(e.contains(says), "{says}: {e}");
    }
}

#[test]
fn a_fetch_from_a_copy_installs_only_when_every_file_is_right() {
    let (a, b) = (b"# a\nv 0.0 0.0 0.0\n".as_slice(), b"# b\n".as_slice());
    let m = Manifest::parse(
        &format!("version = 1\n{}{}", entry("a", "a.obj", a), entry("b", "b.obj", b)),
        Path::new("c.toml"),
    )
    .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (copy, to) = (tmp.path().join("copy"), tmp.path().join("to"));
    std::fs::create_dir_all(&copy).unwrap();
    std::fs::write(copy.join("a.obj"), a).unwrap();
    std::fs::write(copy.join("b.obj"), b"# B\n").unwrap();
    let entries = m.select(&[]).unwrap();
    let mut lines = Vec::new();
    let e = fetch(&entries, &to, &From::Copy(copy.clone()), &mut |l| lines.push(l.to_string())).unwrap_err();
    assert!(format!("{e:#}").contains("b.obj has SHA-256"), "{e:#}");
    assert!(!to.join("a.obj").exists(), "nothing is installed while a file is wrong");
    // a is kept staged; with b right the fetch completes, and the work folder is gone
    std::fs::write(copy.join("b.obj"), b).unwrap();
    let done = fetch(&entries, &to, &From::Copy(copy), &mut |l| lines.push(l.to_string())).unwrap();
    assert_eq!(done.installed, ["a.obj", "b.obj"]);
    assert_eq!(std::fs::read(to.join("b.obj")).unwrap(), b);
    assert!(!to.join(WORK_DIR).exists());
    assert!(lines.iter().any(|l| l.contains("[1/2] a: built before")), "{lines:?}");
    // again: everything is there
    let done = fetch(&entries, &to, &From::Copy(tmp.path().join("none")), &mut |_| {});
    assert!(done.is_err(), "a missing --from folder is refused");
    let done = fetch(&entries, &to, &From::Copy(tmp.path().to_path_buf()), &mut |_| {}).unwrap();
    assert_eq!((done.installed.len(), done.present.len()), (0, 2));
}
