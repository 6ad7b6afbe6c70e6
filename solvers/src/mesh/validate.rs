//! Mesh validation: every defect a solver could trip on, each named by its element, so a
//! bad input ends in a clear message instead of a panic or a silent wrong answer.

use super::topology::{self, is_proper};
use super::{Mesh, MeshError};
use std::fmt;

/// One defect of a mesh. Vertex and face numbers are 0-based indices into the mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Problem {
    #[error("face {face} refers to vertex {index}, but the mesh has only {n_vertices} vertices")]
    IndexOutOfRange { face: usize, index: usize, n_vertices: usize },
    #[error("{count} {} not used by any face (first: vertex {first})", if *count == 1 { "vertex is" } else { "vertices are" })]
    UnreferencedVertices { count: usize, first: usize },
    #[error("face {face} is degenerate (zero area)")]
    DegenerateFace { face: usize },
    #[error("face {face} duplicates face {other} (same three vertices)")]
    DuplicateFace { face: usize, other: usize },
    #[error("edge ({a}, {b}) is shared by {faces} faces (non-manifold)")]
    NonManifoldEdge { a: usize, b: usize, faces: usize },
    #[error("vertex {vertex} is non-manifold (its faces do not form a single fan, e.g. a bow-tie)")]
    NonManifoldVertex { vertex: usize },
    #[error("edge ({a}, {b}) is traversed in the same direction by both its faces (inconsistent orientation)")]
    InconsistentOrientation { a: usize, b: usize },
    #[error("mesh has {count} connected components; a single connected mesh is required")]
    Components { count: usize },
    #[error(
        "mesh has {boundary_loops} boundary {} and Euler characteristic {euler}; param/authalic need a \
         topological disk (1 loop, Euler characteristic 1)",
        if *boundary_loops == 1 { "loop" } else { "loops" }
    )]
    NotDisk { boundary_loops: usize, euler: i64 },
    #[error("vertex {vertex} has a non-finite coordinate (NaN or infinity)")]
    NonFinitePosition { vertex: usize },
    #[error(
        "the {} coordinates run from {lo:e} (vertex {lo_vertex}) to {hi:e} (vertex {hi_vertex}), a span f64 \
         cannot hold; rescale the mesh",
        ["x", "y", "z"][*axis]
    )]
    CoordinateRange { axis: usize, lo: f64, lo_vertex: usize, hi: f64, hi_vertex: usize },
    #[error("mesh has no faces")]
    Empty,
    #[error(
        "{count} {} off the plane z = 0 (first: vertex {first}, z = {z}); the deform task needs a planar mesh",
        if *count == 1 { "vertex is" } else { "vertices are" }
    )]
    NotPlanar { count: usize, first: usize, z: f64 },
    #[error("face {face} is clockwise in the plane; the deform task needs counter-clockwise faces (the rest pose)")]
    ClockwiseFace { face: usize },
    #[error("mesh has no interior vertex; the authalic task moves interior vertices and needs at least one")]
    NoInterior,
}

/// The tasks a mesh is validated for: each task's run refuses exactly what
/// [`validate_for`] reports for it.
/// Its string (`task = "param"` in a config) is [`Task::as_str`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Task {
    /// A topological disk (3D or planar, either orientation). The default task of a config.
    #[default]
    Param,
    /// A planar (z = 0), counter-clockwise shape; holes allowed.
    Deform,
    /// A topological disk with at least one interior vertex.
    Authalic,
}

impl Task {
    /// Every task, in the README's order.
    pub const ALL: [Task; 3] = [Task::Param, Task::Deform, Task::Authalic];

    pub fn as_str(&self) -> &'static str {
        match self {
            Task::Param => "param",
            Task::Deform => "deform",
            Task::Authalic => "authalic",
        }
    }
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A task name that names no [`Task`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown task '{0}' (known: {known})", known = Task::ALL.map(|t| t.as_str()).join(", "))]
pub struct UnknownTask(pub String);

impl std::str::FromStr for Task {
    type Err = UnknownTask;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Task::ALL.into_iter().find(|t| t.as_str() == s).ok_or_else(|| UnknownTask(s.to_string()))
    }
}

impl Problem {
    /// Plural name of the kind, for "... and N more <kind>" summaries.
    pub fn kind(&self) -> &'static str {
        match self {
            Problem::IndexOutOfRange { .. } => "out-of-range indices",
            Problem::UnreferencedVertices { .. } => "unreferenced-vertex reports",
            Problem::DegenerateFace { .. } => "degenerate faces",
            Problem::DuplicateFace { .. } => "duplicate faces",
            Problem::NonManifoldEdge { .. } => "non-manifold edges",
            Problem::NonManifoldVertex { .. } => "non-manifold vertices",
            Problem::InconsistentOrientation { .. } => "inconsistently oriented edges",
            Problem::Components { .. } => "component reports",
            Problem::NotDisk { .. } => "topology reports",
            Problem::NonFinitePosition { .. } => "non-finite vertices",
            Problem::CoordinateRange { .. } => "coordinate-range reports",
            Problem::Empty => "empty-mesh reports",
            Problem::NotPlanar { .. } => "planarity reports",
            Problem::ClockwiseFace { .. } => "clockwise faces",
            Problem::NoInterior => "interior reports",
        }
    }
}

/// One line per problem, at most `max_per_kind` of each kind followed by "... and N more <kind>".
/// Keeps messages readable for a mesh with thousands of bad faces.
pub fn summarize_problems(problems: &[Problem], max_per_kind: usize, sep: &str) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < problems.len() {
        let kind = std::mem::discriminant(&problems[i]);
        let run = problems[i..].iter().take_while(|p| std::mem::discriminant(*p) == kind).count();
        parts.extend(problems[i..i + run.min(max_per_kind)].iter().map(|p| p.to_string()));
        if run > max_per_kind {
            parts.push(format!("... and {} more {}", run - max_per_kind, problems[i].kind()));
        }
        i += run;
    }
    parts.join(sep)
}

/// Counts and defects of a mesh, as found by [`validate`].
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationReport {
    /// The mesh's source (file path or `generated:<name>`).
    pub source: String,
    pub n_vertices: usize,
    pub n_faces: usize,
    /// Undirected edges of the faces that take part in topology (see [`validate`]).
    pub n_edges: usize,
    pub boundary_loops: usize,
    /// `V - E + F` over referenced vertices and topology faces.
    pub euler: i64,
    pub components: usize,
    pub problems: Vec<Problem>,
}

impl ValidationReport {
    pub fn is_ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// `Err(MeshError::Invalid)` naming the source when any problem was found.
    pub fn into_result(self) -> Result<(), MeshError> {
        if self.is_ok() {
            Ok(())
        } else {
            Err(MeshError::Invalid { path: self.source, problems: self.problems })
        }
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

impl fmt::Display for ValidationReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {}, {}, {}, {}, Euler characteristic {}, {}",
            self.source,
            plural(self.n_vertices, "vertex", "vertices"),
            plural(self.n_faces, "face", "faces"),
            plural(self.n_edges, "edge", "edges"),
            plural(self.boundary_loops, "boundary loop", "boundary loops"),
            self.euler,
            plural(self.components, "component", "components"),
        )?;
        if self.is_ok() {
            write!(f, "  no problems found")
        } else {
            writeln!(f, "  {}:", plural(self.problems.len(), "problem", "problems"))?;
            write!(f, "  - {}", summarize_problems(&self.problems, 20, "\n  - "))
        }
    }
}

/// Check `mesh` for everything a solver could trip on; with `require_disk`, also require a
/// topological disk (one boundary loop, Euler characteristic 1).
///
/// Never panics. Faces with an out-of-range or repeated index, and repeats of an earlier
/// face, are reported and then left out of the topology checks (edges, loops, fans,
/// components, Euler characteristic), so each defect is reported once. O(F log F).
pub fn validate(mesh: &Mesh, require_disk: bool) -> ValidationReport {
    let n = mesh.n_vertices();
    let mut problems = Vec::new();
    if mesh.faces.is_empty() {
        problems.push(Problem::Empty);
    }
    problems.extend(
        (0..n)
            .filter(|&v| mesh.positions[v].iter().any(|c| !c.is_finite()))
            .map(|vertex| Problem::NonFinitePosition { vertex }),
    );

    let in_range: Vec<bool> = mesh.faces.iter().map(|f| f.iter().all(|&v| v < n)).collect();
    for (face, f) in mesh.faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&v| v >= n) {
            problems.push(Problem::IndexOutOfRange { face, index, n_vertices: n });
        }
    }

    let range = coordinate_range(mesh);
    let range_ok = range.is_none();
    problems.extend(range);

    // Degenerate: repeated index, or area below the manifest's threshold (1e-14 * diag^2),
    // measured at unit extent when the squares of the file's units over- or underflow.
    let (diag, m) = (mesh.bbox_diagonal(), mesh.extent());
    let (k, tiny) = match 1e-14 * diag * diag {
        tiny if tiny.is_normal() || !range_ok || !(m > 0.0) => (1.0, tiny),
        _ => (1.0 / m, 1e-14 * (diag / m) * (diag / m)),
    };
    for (face, f) in mesh.faces.iter().enumerate() {
        if in_range[face] && (!is_proper(f, n) || (tiny.is_finite() && mesh.face_area_scaled(face, k) <= tiny)) {
            problems.push(Problem::DegenerateFace { face });
        }
    }

    // Duplicates: same vertex set in any order; the first occurrence stays in the topology.
    let mut keyed: Vec<([usize; 3], usize)> = (0..mesh.n_faces())
        .filter(|&f| is_proper(&mesh.faces[f], n))
        .map(|f| {
            let mut k = mesh.faces[f];
            k.sort_unstable();
            (k, f)
        })
        .collect();
    keyed.sort_unstable();
    let mut is_repeat = vec![false; mesh.n_faces()];
    let mut dups = Vec::new();
    let mut first = 0;
    for w in 1..keyed.len() {
        if keyed[w].0 != keyed[first].0 {
            first = w;
        } else {
            is_repeat[keyed[w].1] = true;
            dups.push(Problem::DuplicateFace { face: keyed[w].1, other: keyed[first].1 });
        }
    }
    dups.sort_by_key(|p| if let Problem::DuplicateFace { face, .. } = p { *face } else { 0 });
    problems.extend(dups);

    let mut referenced = vec![false; n];
    for (_, t) in mesh.faces.iter().enumerate().filter(|(f, _)| in_range[*f]) {
        for &v in t {
            referenced[v] = true;
        }
    }
    let unreferenced = referenced.iter().filter(|&&r| !r).count();
    if let Some(first) = referenced.iter().position(|&r| !r) {
        if !mesh.faces.is_empty() {
            problems.push(Problem::UnreferencedVertices { count: unreferenced, first });
        }
    }

    let topo: Vec<[usize; 3]> =
        (0..mesh.n_faces()).filter(|&f| is_proper(&mesh.faces[f], n) && !is_repeat[f]).map(|f| mesh.faces[f]).collect();
    let edges = topology::edges(&topo, n);
    let mut on_bad_edge = vec![false; n];
    for e in edges.iter().filter(|e| e.faces() > 2) {
        problems.push(Problem::NonManifoldEdge { a: e.a, b: e.b, faces: e.faces() });
        on_bad_edge[e.a] = true;
        on_bad_edge[e.b] = true;
    }
    // A vertex on a non-manifold edge is already reported through the edge.
    let fans = topology::fans_per_vertex(&topo, n);
    problems
        .extend((0..n).filter(|&v| fans[v] > 1 && !on_bad_edge[v]).map(|vertex| Problem::NonManifoldVertex { vertex }));
    problems.extend(
        edges
            .iter()
            .filter(|e| e.faces() == 2 && e.is_inconsistent())
            .map(|e| Problem::InconsistentOrientation { a: e.a, b: e.b }),
    );

    let loops = topology::boundary_loops_of(&edges, n).len();
    let euler = topology::referenced_vertices(&topo, n) as i64 - edges.len() as i64 + topo.len() as i64;
    let components = topology::components(&topo, n);
    if components > 1 {
        problems.push(Problem::Components { count: components });
    }
    if require_disk && !topo.is_empty() && (loops != 1 || euler != 1) {
        problems.push(Problem::NotDisk { boundary_loops: loops, euler });
    }
    ValidationReport {
        source: mesh.source.clone(),
        n_vertices: n,
        n_faces: mesh.n_faces(),
        n_edges: edges.len(),
        boundary_loops: loops,
        euler,
        components,
        problems,
    }
}

/// The first axis whose coordinates span more than an `f64` holds, or so little that areas
/// cannot be measured even at unit extent (a subnormal span); `None` when all are usable.
fn coordinate_range(mesh: &Mesh) -> Option<Problem> {
    let finite = || mesh.positions.iter().enumerate().filter(|(_, p)| p.iter().all(|c| c.is_finite()));
    (0..3).find_map(|axis| {
        let (lo_vertex, lo) = finite().map(|(v, p)| (v, p[axis])).min_by(|a, b| a.1.total_cmp(&b.1))?;
        let (hi_vertex, hi) = finite().map(|(v, p)| (v, p[axis])).max_by(|a, b| a.1.total_cmp(&b.1))?;
        let span = hi - lo;
        (!span.is_finite() || (span > 0.0 && !span.is_normal())).then_some(Problem::CoordinateRange {
            axis,
            lo,
            lo_vertex,
            hi,
            hi_vertex,
        })
    })
}

/// [`validate`] with everything the run of `task` refuses in a mesh: `param` and `authalic`
/// need a topological disk, `authalic` an interior vertex, `deform` a planar (z = 0) shape
/// whose faces are counter-clockwise in its area-1 rest pose. The run preambles call this, so
/// `mapbench validate --task T` and a run of `T` cannot disagree about a mesh.
pub fn validate_for(mesh: &Mesh, task: Task) -> ValidationReport {
    let mut report = validate(mesh, task != Task::Deform);
    let sound = report.is_ok();
    match task {
        Task::Param => {}
        Task::Deform => {
            // Within 1e-12 of the diagonal counts as z = 0: exporters write -0 and 1e-17.
            let scale = mesh.bbox_diagonal().max(f64::MIN_POSITIVE);
            let off: Vec<usize> = (0..mesh.n_vertices())
                .filter(|&v| mesh.positions[v][2].is_finite() && !(mesh.positions[v][2].abs() <= 1e-12 * scale))
                .collect();
            if let Some(&first) = off.first() {
                report.problems.push(Problem::NotPlanar { count: off.len(), first, z: mesh.positions[first][2] });
            } else if sound {
                // The orientation the solver sees: that of the normalized rest pose.
                let rest = mesh.normalized();
                let xy = |v: usize| [rest.positions[v][0], rest.positions[v][1]];
                report.problems.extend(
                    (0..rest.n_faces())
                        .filter(|&t| super::signed_area(rest.faces[t].map(xy)) <= 0.0)
                        .map(|face| Problem::ClockwiseFace { face }),
                );
            }
        }
        Task::Authalic => {
            if sound && report.boundary_loops == 1 {
                let mut on_boundary = vec![false; mesh.n_vertices()];
                topology::boundary_loops(&mesh.faces, mesh.n_vertices())
                    .iter()
                    .flatten()
                    .for_each(|&v| on_boundary[v] = true);
                if on_boundary.iter().all(|&b| b) {
                    report.problems.push(Problem::NoInterior);
                }
            }
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tasks_round_trip_through_their_names() {
        for t in Task::ALL {
            assert_eq!(t.as_str().parse::<Task>(), Ok(t));
            assert_eq!(t.to_string(), t.as_str());
            let de = serde::de::value::StrDeserializer::<serde::de::value::Error>::new(t.as_str());
            assert_eq!(<Task as serde::Deserialize>::deserialize(de), Ok(t));
        }
        let err = "Param".parse::<Task>().unwrap_err().to_string();
        assert_eq!(err, "unknown task 'Param' (known: param, deform, authalic)");
    }

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

    fn problems(mesh: &Mesh, require_disk: bool) -> Vec<Problem> {
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
        assert_eq!(problems(&m, false), vec![Problem::IndexOutOfRange { face: 8, index: 12, n_vertices: 9 }]);
        assert_eq!(messages(&m, false), vec!["face 8 refers to vertex 12, but the mesh has only 9 vertices"]);
        // all indices bad, huge values: no panic
        let m = Mesh::new("t", vec![[0.0; 3]], vec![[usize::MAX, 5, 7]]);
        let r = validate(&m, true);
        assert!(r.problems.contains(&Problem::IndexOutOfRange { face: 0, index: usize::MAX, n_vertices: 1 }));
    }

    #[test]
    fn unreferenced_vertices() {
        let mut m = grid();
        m.positions.push([5.0, 5.0, 0.0]);
        m.positions.push([6.0, 5.0, 0.0]);
        assert_eq!(problems(&m, true), vec![Problem::UnreferencedVertices { count: 2, first: 9 }]);
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
        assert!(p.contains(&Problem::DegenerateFace { face: 8 }), "{p:?}");
        assert!(p.contains(&Problem::DegenerateFace { face: 9 }), "{p:?}");
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
            vec![Problem::DuplicateFace { face: 8, other: 0 }, Problem::DuplicateFace { face: 9, other: 0 }],
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
        assert!(p.contains(&Problem::NonManifoldEdge { a: 1, b: 4, faces: 3 }), "{p:?}");
        // its end vertices are reported through the edge only
        assert!(!p.iter().any(|p| matches!(p, Problem::NonManifoldVertex { .. })), "{p:?}");
        assert!(messages(&m, false).contains(&"edge (1, 4) is shared by 3 faces (non-manifold)".to_string()));
    }

    #[test]
    fn non_manifold_vertex_bow_tie() {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [-1.0, -1.0, 0.0]];
        let m = Mesh::new("t", positions, vec![[0, 1, 2], [0, 3, 4]]);
        let r = validate(&m, true);
        assert!(r.problems.contains(&Problem::NonManifoldVertex { vertex: 0 }), "{r}");
        assert_eq!(
            r.problems[0].to_string(),
            "vertex 0 is non-manifold (its faces do not form a single fan, e.g. a bow-tie)"
        );
        assert!(r.problems.contains(&Problem::NotDisk { boundary_loops: 2, euler: 1 }), "{r}");
        // a closed fan touching an open fan at one vertex (cone tip glued to a disk)
        let mut faces: Vec<[usize; 3]> = (1..=4).map(|i| [0, i, i % 4 + 1]).collect();
        faces.push([0, 5, 6]);
        let positions: Vec<[f64; 3]> = (0..7).map(|i| [i as f64, (i * i) as f64, (i % 3) as f64]).collect();
        let r = validate(&Mesh::new("t", positions, faces), false);
        assert!(r.problems.contains(&Problem::NonManifoldVertex { vertex: 0 }), "{r}");
    }

    #[test]
    fn inconsistent_orientation() {
        let mut m = grid();
        m.faces[1] = [0, 3, 4]; // reversed: now traverses 4 -> 0 like face 0 and 3 -> 4 like face 3
        let p = problems(&m, false);
        assert!(p.contains(&Problem::InconsistentOrientation { a: 0, b: 4 }), "{p:?}");
        assert!(p.contains(&Problem::InconsistentOrientation { a: 3, b: 4 }), "{p:?}");
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
        assert_eq!(p, vec![Problem::Components { count: 2 }, Problem::NotDisk { boundary_loops: 2, euler: 2 }]);
        assert_eq!(p[0].to_string(), "mesh has 2 connected components; a single connected mesh is required");
        assert_eq!(
            p[1].to_string(),
            "mesh has 2 boundary loops and Euler characteristic 2; param/authalic need a topological disk \
             (1 loop, Euler characteristic 1)"
        );
        // without require_disk only the components are a problem
        assert_eq!(problems(&m, false), vec![Problem::Components { count: 2 }]);
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
        assert_eq!(p, vec![Problem::NotDisk { boundary_loops: 2, euler: 0 }]);
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
        assert_eq!(p, vec![Problem::NonFinitePosition { vertex: 4 }, Problem::NonFinitePosition { vertex: 7 }]);
        assert_eq!(p[0].to_string(), "vertex 4 has a non-finite coordinate (NaN or infinity)");
    }

    #[test]
    fn empty_mesh() {
        let m = Mesh::new("t", vec![[0.0; 3]; 3], vec![]);
        assert_eq!(problems(&m, true), vec![Problem::Empty]);
        assert_eq!(Problem::Empty.to_string(), "mesh has no faces");
        let m = Mesh::new("t", vec![], vec![]);
        assert_eq!(problems(&m, true), vec![Problem::Empty]);
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
            assert_eq!(problems(&m, false), vec![Problem::DegenerateFace { face: 8 }], "{k}");
        }
    }

    #[test]
    fn a_span_beyond_f64_is_a_problem_naming_the_vertices() {
        let mut m = grid();
        m.positions[0][0] = -1e308;
        m.positions[8][0] = 1e308;
        let p = problems(&m, true);
        assert_eq!(p, vec![Problem::CoordinateRange { axis: 0, lo: -1e308, lo_vertex: 0, hi: 1e308, hi_vertex: 8 }]);
        assert_eq!(
            p[0].to_string(),
            "the x coordinates run from -1e308 (vertex 0) to 1e308 (vertex 8), a span f64 cannot hold; rescale the mesh"
        );
        // a subnormal span cannot be measured either
        let m = scaled(&grid(), 1e-320);
        assert!(
            matches!(problems(&m, true)[..], [Problem::CoordinateRange { axis: 0, .. }, ..]),
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
        assert_eq!(p, vec![Problem::NotPlanar { count: 2, first: 4, z: 0.5 }]);
        assert_eq!(
            p[0].to_string(),
            "2 vertices are off the plane z = 0 (first: vertex 4, z = 0.5); the deform task needs a planar mesh"
        );
        // z = const is a plane, but not the one deform works in; param takes either
        let mut raised = grid();
        raised.positions.iter_mut().for_each(|p| p[2] = 5.0);
        assert!(matches!(validate_for(&raised, Task::Deform).problems[..], [Problem::NotPlanar { count: 9, .. }]));
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
        assert_eq!(p, (0..8).map(|face| Problem::ClockwiseFace { face }).collect::<Vec<_>>());
        assert_eq!(
            p[0].to_string(),
            "face 0 is clockwise in the plane; the deform task needs counter-clockwise faces (the rest pose)"
        );
        // one face folded over in the plane (consistently oriented, so only deform minds)
        let mut folded = grid();
        folded.positions[4] = [2.5, 2.5, 0.0];
        let p = validate_for(&folded, Task::Deform).problems;
        assert!(!p.is_empty() && p.iter().all(|p| matches!(p, Problem::ClockwiseFace { .. })), "{p:?}");
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
        assert_eq!(p, vec![Problem::NoInterior]);
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
}
