//! Validation: each defect found, named by its element, and each task's rules.

use super::*;
use crate::tasks::{validate_for, Task};

/// 3x3 grid of vertices (2x2 quads, 8 counter-clockwise triangles): a valid disk.
fn grid() -> Mesh {
    let mut positions = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            positions.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut faces = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            let v = 3 * j + i;
            faces.push([v, v + 1, v + 4]);
            faces.push([v, v + 4, v + 3]);
        }
    }
    Mesh::new("test:grid", positions, faces)
}

fn problems(mesh: &Mesh, require_disk: bool) -> Vec<Defect> {
    validate(mesh, require_disk).problems
}

fn messages(mesh: &Mesh, require_disk: bool) -> Vec<String> {
    problems(mesh, require_disk).iter().map(|p| p.to_string()).collect()
}

#[test]
fn valid_disk_passes() {
    let r = validate(&grid(), true);
    assert!(r.is_ok(), "{r}");
    assert_eq!((r.n_vertices, r.n_faces, r.n_edges), (9, 8, 16));
    assert_eq!((r.boundary_loops, r.euler, r.components), (1, 1, 1));
    assert!(r.to_string().contains("no problems found"));
    assert!(r.into_result().is_ok());
}

#[test]
fn index_out_of_range_is_reported_and_skipped() {
    let mut m = grid();
    m.faces.push([0, 12, 3]);
    assert_eq!(problems(&m, false), vec![Defect::IndexOutOfRange { face: 8, index: 12, n_vertices: 9 }]);
    assert_eq!(messages(&m, false), vec!["face 8 refers to vertex 12, but the mesh has only 9 vertices"]);
    // all indices bad, huge values: no panic
    let m = Mesh::new("t", vec![[0.0; 3]], vec![[usize::MAX, 5, 7]]);
    let r = validate(&m, true);
    assert!(r.problems.contains(&Defect::IndexOutOfRange { face: 0, index: usize::MAX, n_vertices: 1 }));
}

#[test]
fn unreferenced_vertices() {
    let mut m = grid();
    m.positions.push([5.0, 5.0, 0.0]);
    m.positions.push([6.0, 5.0, 0.0]);
    assert_eq!(problems(&m, true), vec![Defect::UnreferencedVertices { count: 2, first: 9 }]);
    assert_eq!(messages(&m, true), vec!["2 vertices are not used by any face (first: vertex 9)"]);
    m.positions.pop();
    assert_eq!(messages(&m, true), vec!["1 vertex is not used by any face (first: vertex 9)"]);
}

#[test]
fn degenerate_faces() {
    // a collinear triple and a repeated index
    let mut m = grid();
    m.positions.push([0.5, 0.0, 0.0]); // 9, collinear with 0 and 1
    m.faces.push([0, 9, 1]);
    m.faces.push([4, 4, 5]);
    let p = problems(&m, false);
    assert!(p.contains(&Defect::DegenerateFace { face: 8 }), "{p:?}");
    assert!(p.contains(&Defect::DegenerateFace { face: 9 }), "{p:?}");
    assert!(messages(&m, false).contains(&"face 8 is degenerate (zero area)".to_string()));
}

#[test]
fn duplicate_faces_any_orientation() {
    let mut m = grid();
    m.faces.push([4, 0, 1]); // same as face 0, rotated
    m.faces.push([0, 4, 1]); // same as face 0, reversed
    let p = problems(&m, true);
    assert_eq!(
        p,
        vec![Defect::DuplicateFace { face: 8, other: 0 }, Defect::DuplicateFace { face: 9, other: 0 }],
        "duplicates must not also show up as topology problems"
    );
    assert_eq!(p[0].to_string(), "face 8 duplicates face 0 (same three vertices)");
}

#[test]
fn non_manifold_edge() {
    let mut m = grid();
    m.positions.push([0.5, 0.5, 1.0]); // 9
    m.faces.push([4, 1, 9]); // a third face on the interior edge (1, 4)
    let p = problems(&m, false);
    assert!(p.contains(&Defect::NonManifoldEdge { a: 1, b: 4, faces: 3 }), "{p:?}");
    // its end vertices are reported through the edge only
    assert!(!p.iter().any(|p| matches!(p, Defect::NonManifoldVertex { .. })), "{p:?}");
    assert!(messages(&m, false).contains(&"edge (1, 4) is shared by 3 faces (non-manifold)".to_string()));
}

#[test]
fn non_manifold_vertex_bow_tie() {
    let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [-1.0, -1.0, 0.0]];
    let m = Mesh::new("t", positions, vec![[0, 1, 2], [0, 3, 4]]);
    let r = validate(&m, true);
    assert!(r.problems.contains(&Defect::NonManifoldVertex { vertex: 0 }), "{r}");
    assert_eq!(
        r.problems[0].to_string(),
        "vertex 0 is non-manifold (its faces do not form a single fan, e.g. a bow-tie)"
    );
    assert!(r.problems.contains(&Defect::NotDisk { boundary_loops: 2, euler: 1 }), "{r}");
    // a closed fan touching an open fan at one vertex (cone tip glued to a disk)
    let mut faces: Vec<[usize; 3]> = (1..=4).map(|i| [0, i, i % 4 + 1]).collect();
    faces.push([0, 5, 6]);
    let positions: Vec<[f64; 3]> = (0..7).map(|i| [i as f64, (i * i) as f64, (i % 3) as f64]).collect();
    let r = validate(&Mesh::new("t", positions, faces), false);
    assert!(r.problems.contains(&Defect::NonManifoldVertex { vertex: 0 }), "{r}");
}

#[test]
fn inconsistent_orientation() {
    let mut m = grid();
    m.faces[1] = [0, 3, 4]; // reversed: now traverses 4 -> 0 like face 0 and 3 -> 4 like face 3
    let p = problems(&m, false);
    assert!(p.contains(&Defect::InconsistentOrientation { a: 0, b: 4 }), "{p:?}");
    assert!(p.contains(&Defect::InconsistentOrientation { a: 3, b: 4 }), "{p:?}");
    assert!(messages(&m, false).contains(
        &"edge (0, 4) is traversed in the same direction by both its faces (inconsistent orientation)".into()
    ));
}

#[test]
fn components_and_not_disk() {
    let mut m = grid();
    let off = m.n_vertices();
    m.positions.extend([[10.0, 0.0, 0.0], [11.0, 0.0, 0.0], [10.0, 1.0, 0.0]]);
    m.faces.push([off, off + 1, off + 2]);
    let p = problems(&m, true);
    assert_eq!(p, vec![Defect::Components { count: 2 }, Defect::NotDisk { boundary_loops: 2, euler: 2 }]);
    assert_eq!(p[0].to_string(), "mesh has 2 connected components; a single connected mesh is required");
    assert_eq!(
        p[1].to_string(),
        "mesh has 2 boundary loops and Euler characteristic 2; param/authalic need a topological disk \
         (1 loop, Euler characteristic 1)"
    );
    // without require_disk only the components are a problem
    assert_eq!(problems(&m, false), vec![Defect::Components { count: 2 }]);
}

#[test]
fn annulus_is_not_a_disk() {
    let m = 8;
    let mut positions = Vec::new();
    for r in [1.0, 2.0] {
        for i in 0..m {
            let t = i as f64 * std::f64::consts::TAU / m as f64;
            positions.push([r * t.cos(), r * t.sin(), 0.0]);
        }
    }
    let mut faces = Vec::new();
    for i in 0..m {
        let j = (i + 1) % m;
        faces.push([i, m + i, m + j]);
        faces.push([i, m + j, j]);
    }
    let mesh = Mesh::new("t", positions, faces);
    assert!(validate(&mesh, false).is_ok());
    let p = problems(&mesh, true);
    assert_eq!(p, vec![Defect::NotDisk { boundary_loops: 2, euler: 0 }]);
    assert_eq!(
        p[0].to_string(),
        "mesh has 2 boundary loops and Euler characteristic 0; param/authalic need a topological disk \
         (1 loop, Euler characteristic 1)"
    );
}

#[test]
fn non_finite_position() {
    let mut m = grid();
    m.positions[4][2] = f64::NAN;
    m.positions[7][0] = f64::INFINITY;
    let p = problems(&m, true);
    assert_eq!(p, vec![Defect::NonFinitePosition { vertex: 4 }, Defect::NonFinitePosition { vertex: 7 }]);
    assert_eq!(p[0].to_string(), "vertex 4 has a non-finite coordinate (NaN or infinity)");
}

#[test]
fn empty_mesh() {
    let m = Mesh::new("t", vec![[0.0; 3]; 3], vec![]);
    assert_eq!(problems(&m, true), vec![Defect::Empty]);
    assert_eq!(Defect::Empty.to_string(), "mesh has no faces");
    let m = Mesh::new("t", vec![], vec![]);
    assert_eq!(problems(&m, true), vec![Defect::Empty]);
}

#[test]
fn into_result_names_the_source_and_report_caps_listing() {
    let mut m = grid();
    m.source = "/data/broken.obj".into();
    for k in 0..25 {
        m.faces.push([k % 9, k % 9, (k + 1) % 9]);
    }
    let r = validate(&m, true);
    let text = r.to_string();
    assert!(text.starts_with("/data/broken.obj: 9 vertices, 33 faces"), "{text}");
    assert!(text.contains("face 27 is degenerate"), "{text}");
    assert!(!text.contains("face 28 is degenerate"), "{text}");
    assert!(text.contains("... and 5 more degenerate faces"), "{text}");
    let err = r.into_result().unwrap_err();
    let msg = err.to_string();
    assert!(msg.starts_with("/data/broken.obj: invalid mesh: face 8 is degenerate (zero area); "), "{msg}");
    assert!(msg.contains("... and 15 more degenerate faces"), "{msg}");
    assert!(
        matches!(err, MeshError::Invalid { ref path, ref problems } if path == "/data/broken.obj" && problems.len() == 25)
    );
}

fn scaled(m: &Mesh, k: f64) -> Mesh {
    Mesh::new(m.source.clone(), m.positions.iter().map(|p| p.map(|c| c * k)).collect(), m.faces.clone())
}

#[test]
fn huge_and_tiny_coordinates_are_measured_at_unit_extent() {
    for k in [1e300, 1e-300, 1e160, 1e-160] {
        let m = scaled(&grid(), k);
        let r = validate(&m, true);
        assert!(r.is_ok(), "{k}: {r}");
        for task in Task::ALL {
            assert!(validate_for(&m, task).is_ok(), "{k} {task:?}: {}", validate_for(&m, task));
        }
        // a collinear face is still degenerate at that scale
        let mut m = m;
        m.positions.push([0.5 * k, 0.0, 0.0]);
        m.faces.push([0, 9, 1]);
        assert_eq!(problems(&m, false), vec![Defect::DegenerateFace { face: 8 }], "{k}");
    }
}

#[test]
fn a_span_beyond_f64_is_a_problem_naming_the_vertices() {
    let mut m = grid();
    m.positions[0][0] = -1e308;
    m.positions[8][0] = 1e308;
    let p = problems(&m, true);
    assert_eq!(p, vec![Defect::CoordinateRange { axis: 0, lo: -1e308, lo_vertex: 0, hi: 1e308, hi_vertex: 8 }]);
    assert_eq!(
        p[0].to_string(),
        "the x coordinates run from -1e308 (vertex 0) to 1e308 (vertex 8), a span f64 cannot hold; rescale the mesh"
    );
    // a subnormal span cannot be measured either
    let m = scaled(&grid(), 1e-320);
    assert!(
        matches!(problems(&m, true)[..], [Defect::CoordinateRange { axis: 0, .. }, ..]),
        "{:?}",
        problems(&m, true)
    );
}

#[test]
fn deform_needs_a_planar_counter_clockwise_shape() {
    let mut lifted = grid();
    lifted.positions[4][2] = 0.5;
    lifted.positions[7][2] = -0.25;
    assert!(validate(&lifted, false).is_ok());
    let p = validate_for(&lifted, Task::Deform).problems;
    assert_eq!(p, vec![Defect::NotPlanar { count: 2, first: 4, z: 0.5 }]);
    assert_eq!(
        p[0].to_string(),
        "2 vertices are off the plane z = 0 (first: vertex 4, z = 0.5); the deform task needs a planar mesh"
    );
    // z = const is a plane, but not the one deform works in; param takes either
    let mut raised = grid();
    raised.positions.iter_mut().for_each(|p| p[2] = 5.0);
    assert!(matches!(validate_for(&raised, Task::Deform).problems[..], [Defect::NotPlanar { count: 9, .. }]));
    assert!(validate_for(&raised, Task::Param).is_ok());
    // exporters' noise (-0, 1e-17) is z = 0
    let mut noisy = grid();
    noisy.positions[1][2] = -0.0;
    noisy.positions[2][2] = 1e-17;
    assert!(validate_for(&noisy, Task::Deform).is_ok());

    let mut cw = grid();
    cw.faces.iter_mut().for_each(|f| f.swap(1, 2));
    assert!(validate_for(&cw, Task::Param).is_ok() && validate_for(&cw, Task::Authalic).is_ok());
    let p = validate_for(&cw, Task::Deform).problems;
    assert_eq!(p, (0..8).map(|face| Defect::ClockwiseFace { face }).collect::<Vec<_>>());
    assert_eq!(
        p[0].to_string(),
        "face 0 is clockwise in the plane; the deform task needs counter-clockwise faces (the rest pose)"
    );
    // one face folded over in the plane (consistently oriented, so only deform minds)
    let mut folded = grid();
    folded.positions[4] = [2.5, 2.5, 0.0];
    let p = validate_for(&folded, Task::Deform).problems;
    assert!(!p.is_empty() && p.iter().all(|p| matches!(p, Defect::ClockwiseFace { .. })), "{p:?}");
}

#[test]
fn authalic_needs_an_interior_vertex() {
    let fan = Mesh::new(
        "t",
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    assert!(validate_for(&fan, Task::Param).is_ok());
    let p = validate_for(&fan, Task::Authalic).problems;
    assert_eq!(p, vec![Defect::NoInterior]);
    assert_eq!(
        p[0].to_string(),
        "mesh has no interior vertex; the authalic task moves interior vertices and needs at least one"
    );
    assert!(validate_for(&grid(), Task::Authalic).is_ok());
}

#[test]
fn random_soups_never_panic() {
    let mut state = 12345u64;
    let mut next = |m: usize| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 33) as usize) % m
    };
    for _ in 0..300 {
        let n = next(12);
        let positions: Vec<[f64; 3]> = (0..n).map(|_| [next(3) as f64, next(3) as f64, next(2) as f64]).collect();
        let faces: Vec<[usize; 3]> = (0..next(15)).map(|_| [next(n + 2), next(n + 2), next(n + 2)]).collect();
        let mesh = Mesh::new("fuzz", positions, faces);
        let r = validate(&mesh, true);
        let _ = r.to_string();
        for task in [Task::Param, Task::Deform, Task::Authalic] {
            let _ = validate_for(&mesh, task).to_string();
        }
        let _ = topology::boundary_loops(&mesh.faces, n);
    }
}
