//! Mesh validation: every defect a solver could trip on, each named by its element, so a
//! bad input ends in a clear message instead of a panic or a silent wrong answer.

use super::defect::{summarize_problems, Defect};
use super::error::MeshError;
use super::topology::{self, is_proper};
use super::triangle_mesh::Mesh;
use std::fmt;

/// Counts and defects of a mesh, as found by [`validate`].
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationReport {
    /// The mesh's source (file path or `generated:<name>`).
    pub source: String,
    /// Number of vertices, used or not.
    pub n_vertices: usize,
    /// Number of faces, including those left out of the topology checks.
    pub n_faces: usize,
    /// Undirected edges of the faces that take part in topology (see [`validate`]).
    pub n_edges: usize,
    /// Number of boundary loops of the topology faces.
    pub boundary_loops: usize,
    /// `V - E + F` over referenced vertices and topology faces.
    pub euler: i64,
    /// Number of connected components of the topology faces (faces sharing a vertex are connected).
    pub components: usize,
    /// Every defect found, grouped by kind; empty for a usable mesh.
    pub problems: Vec<Defect>,
}

impl ValidationReport {
    /// True when no problem was found.
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
        problems.push(Defect::Empty);
    }
    problems.extend(
        (0..n)
            .filter(|&v| mesh.positions[v].iter().any(|c| !c.is_finite()))
            .map(|vertex| Defect::NonFinitePosition { vertex }),
    );

    let in_range: Vec<bool> = mesh.faces.iter().map(|f| f.iter().all(|&v| v < n)).collect();
    for (face, f) in mesh.faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&v| v >= n) {
            problems.push(Defect::IndexOutOfRange { face, index, n_vertices: n });
        }
    }

    let range = coordinate_range(mesh);
    let range_ok = range.is_none();
    problems.extend(range);

    problems.extend(degenerate_faces(mesh, &in_range, range_ok));

    let (is_repeat, dups) = duplicate_faces(mesh, n);
    problems.extend(dups);

    if !mesh.faces.is_empty() {
        problems.extend(unreferenced_vertices(mesh, &in_range));
    }

    let topo: Vec<[usize; 3]> =
        (0..mesh.n_faces()).filter(|&f| is_proper(&mesh.faces[f], n) && !is_repeat[f]).map(|f| mesh.faces[f]).collect();
    let edges = topology::edges(&topo, n);
    let mut on_bad_edge = vec![false; n];
    for e in edges.iter().filter(|e| e.faces() > 2) {
        problems.push(Defect::NonManifoldEdge { a: e.a, b: e.b, faces: e.faces() });
        on_bad_edge[e.a] = true;
        on_bad_edge[e.b] = true;
    }
    // A vertex on a non-manifold edge is already reported through the edge.
    let fans = topology::fans_per_vertex(&topo, n);
    problems
        .extend((0..n).filter(|&v| fans[v] > 1 && !on_bad_edge[v]).map(|vertex| Defect::NonManifoldVertex { vertex }));
    problems.extend(
        edges
            .iter()
            .filter(|e| e.faces() == 2 && e.is_inconsistent())
            .map(|e| Defect::InconsistentOrientation { a: e.a, b: e.b }),
    );

    let loops = topology::boundary_loops_of(&edges, n).len();
    let euler = topology::referenced_vertices(&topo, n) as i64 - edges.len() as i64 + topo.len() as i64;
    let components = topology::components(&topo, n);
    if components > 1 {
        problems.push(Defect::Components { count: components });
    }
    if require_disk && !topo.is_empty() && (loops != 1 || euler != 1) {
        problems.push(Defect::NotDisk { boundary_loops: loops, euler });
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

/// Degenerate faces (in range): a repeated index, or an area below the manifest's threshold
/// (1e-14 * diag^2), measured at unit extent when the squares of the file's units over- or
/// underflow (`range_ok`: the coordinates' range allows it).
fn degenerate_faces(mesh: &Mesh, in_range: &[bool], range_ok: bool) -> Vec<Defect> {
    let n = mesh.n_vertices();
    let mut problems = Vec::new();
    let (diag, m) = (mesh.bbox_diagonal(), mesh.extent());
    let (k, tiny) = match 1e-14 * diag * diag {
        tiny if tiny.is_normal() || !range_ok || !(m > 0.0) => (1.0, tiny),
        _ => (1.0 / m, 1e-14 * (diag / m) * (diag / m)),
    };
    for (face, f) in mesh.faces.iter().enumerate() {
        if in_range[face] && (!is_proper(f, n) || (tiny.is_finite() && mesh.face_area_scaled(face, k) <= tiny)) {
            problems.push(Defect::DegenerateFace { face });
        }
    }
    problems
}

/// The vertices no face (in range) refers to, as one problem: their count and the first.
fn unreferenced_vertices(mesh: &Mesh, in_range: &[bool]) -> Option<Defect> {
    let mut referenced = vec![false; mesh.n_vertices()];
    for (_, t) in mesh.faces.iter().enumerate().filter(|(f, _)| in_range[*f]) {
        for &v in t {
            referenced[v] = true;
        }
    }
    let unreferenced = referenced.iter().filter(|&&r| !r).count();
    referenced.iter().position(|&r| !r).map(|first| Defect::UnreferencedVertices { count: unreferenced, first })
}

/// Repeats of an earlier face (the same vertex set in any order), as a flag per face and the
/// problems in face order; the first occurrence stays in the topology.
fn duplicate_faces(mesh: &Mesh, n: usize) -> (Vec<bool>, Vec<Defect>) {
    // Grouped by the smallest vertex, each group sorted by the other two, then the face.
    let (_, keyed) = crate::grouping::grouped(n, || {
        (0..mesh.n_faces()).filter(|&f| is_proper(&mesh.faces[f], n)).map(|f| {
            let mut k = mesh.faces[f];
            k.sort_unstable();
            (k[0], (k, f))
        })
    });
    let mut is_repeat = vec![false; mesh.n_faces()];
    let mut dups = Vec::new();
    let mut first = 0;
    for w in 1..keyed.len() {
        if keyed[w].0 != keyed[first].0 {
            first = w;
        } else {
            is_repeat[keyed[w].1] = true;
            dups.push(Defect::DuplicateFace { face: keyed[w].1, other: keyed[first].1 });
        }
    }
    dups.sort_by_key(|p| if let Defect::DuplicateFace { face, .. } = p { *face } else { 0 });
    (is_repeat, dups)
}

/// The first axis whose coordinates span more than an `f64` holds, or so little that areas
/// cannot be measured even at unit extent (a subnormal span); `None` when all are usable.
fn coordinate_range(mesh: &Mesh) -> Option<Defect> {
    let finite = || mesh.positions.iter().enumerate().filter(|(_, p)| p.iter().all(|c| c.is_finite()));
    (0..3).find_map(|axis| {
        let (lo_vertex, lo) = finite().map(|(v, p)| (v, p[axis])).min_by(|a, b| a.1.total_cmp(&b.1))?;
        let (hi_vertex, hi) = finite().map(|(v, p)| (v, p[axis])).max_by(|a, b| a.1.total_cmp(&b.1))?;
        let span = hi - lo;
        (!span.is_finite() || (span > 0.0 && !span.is_normal())).then_some(Defect::CoordinateRange {
            axis,
            lo,
            lo_vertex,
            hi,
            hi_vertex,
        })
    })
}

#[cfg(test)]
#[path = "validate_tests.rs"]
mod tests;
