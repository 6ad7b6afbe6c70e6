//! The defects validation finds in a mesh, each named by its element, and their summary in
//! one message.

/// One defect of a mesh. Vertex and face numbers are 0-based indices into the mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Defect {
    /// A face names a vertex index past the end of the vertex list.
    #[error("face {face} refers to vertex {index}, but the mesh has only {n_vertices} vertices")]
    IndexOutOfRange {
        /// The face holding the bad index.
        face: usize,
        /// The first out-of-range vertex index of that face.
        index: usize,
        /// Number of vertices the mesh has.
        n_vertices: usize,
    },
    /// Vertices that no face (with indices in range) uses; reported once for all of them.
    #[error("{count} {} not used by any face (first: vertex {first})", if *count == 1 { "vertex is" } else { "vertices are" })]
    UnreferencedVertices {
        /// How many vertices are unused.
        count: usize,
        /// The lowest unused vertex.
        first: usize,
    },
    /// A face with a repeated vertex, or an area at most `1e-14` times the squared bounding-box diagonal.
    #[error("face {face} is degenerate (zero area)")]
    DegenerateFace {
        /// The degenerate face.
        face: usize,
    },
    /// A face with the same three vertices (in any order) as an earlier face.
    #[error("face {face} duplicates face {other} (same three vertices)")]
    DuplicateFace {
        /// The repeat, left out of the topology checks.
        face: usize,
        /// The first face with these vertices, which stays in the topology.
        other: usize,
    },
    /// An edge shared by more than two faces.
    #[error("edge ({a}, {b}) is shared by {faces} faces (non-manifold)")]
    NonManifoldEdge {
        /// Smaller vertex of the edge.
        a: usize,
        /// Larger vertex of the edge.
        b: usize,
        /// Number of faces sharing the edge (more than 2).
        faces: usize,
    },
    /// A vertex whose faces form more than one fan; not reported when it lies on a non-manifold edge.
    #[error("vertex {vertex} is non-manifold (its faces do not form a single fan, e.g. a bow-tie)")]
    NonManifoldVertex {
        /// The non-manifold vertex.
        vertex: usize,
    },
    /// An edge of two faces that both traverse it in the same direction.
    #[error("edge ({a}, {b}) is traversed in the same direction by both its faces (inconsistent orientation)")]
    InconsistentOrientation {
        /// Smaller vertex of the edge.
        a: usize,
        /// Larger vertex of the edge.
        b: usize,
    },
    /// The faces form more than one connected component.
    #[error("mesh has {count} connected components; a single connected mesh is required")]
    Components {
        /// Number of connected components.
        count: usize,
    },
    /// Not a topological disk, when one is required (`param`, `authalic`).
    #[error(
        "mesh has {boundary_loops} boundary {} and Euler characteristic {euler}; param/authalic need a \
         topological disk (1 loop, Euler characteristic 1)",
        if *boundary_loops == 1 { "loop" } else { "loops" }
    )]
    NotDisk {
        /// Number of boundary loops found.
        boundary_loops: usize,
        /// Euler characteristic `V - E + F` found.
        euler: i64,
    },
    /// A vertex with a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate (NaN or infinity)")]
    NonFinitePosition {
        /// The vertex with the non-finite coordinate.
        vertex: usize,
    },
    /// The first axis whose finite coordinates span more than an `f64` holds, or a subnormal span.
    #[error(
        "the {} coordinates run from {lo:e} (vertex {lo_vertex}) to {hi:e} (vertex {hi_vertex}), a span f64 \
         cannot hold; rescale the mesh",
        ["x", "y", "z"][*axis]
    )]
    CoordinateRange {
        /// The axis: 0 for x, 1 for y, 2 for z.
        axis: usize,
        /// Smallest finite coordinate on the axis.
        lo: f64,
        /// A vertex holding `lo`.
        lo_vertex: usize,
        /// Largest finite coordinate on the axis.
        hi: f64,
        /// A vertex holding `hi`.
        hi_vertex: usize,
    },
    /// The mesh has no faces.
    #[error("mesh has no faces")]
    Empty,
    /// Vertices off the plane `z = 0`, for the `deform` task; reported once for all of them.
    #[error(
        "{count} {} off the plane z = 0 (first: vertex {first}, z = {z}); the deform task needs a planar mesh",
        if *count == 1 { "vertex is" } else { "vertices are" }
    )]
    NotPlanar {
        /// How many vertices are off the plane.
        count: usize,
        /// The lowest such vertex.
        first: usize,
        /// The z coordinate of `first`, in the file's units.
        z: f64,
    },
    /// A face that is clockwise (or flat) in the normalized rest pose, for the `deform` task.
    #[error("face {face} is clockwise in the plane; the deform task needs counter-clockwise faces (the rest pose)")]
    ClockwiseFace {
        /// The clockwise face.
        face: usize,
    },
    /// Every vertex lies on the boundary, so the `authalic` task has nothing to move.
    #[error("mesh has no interior vertex; the authalic task moves interior vertices and needs at least one")]
    NoInterior,
}

impl Defect {
    /// Plural name of the kind, for "... and N more `<kind>`" summaries.
    pub fn kind(&self) -> &'static str {
        match self {
            Defect::IndexOutOfRange { .. } => "out-of-range indices",
            Defect::UnreferencedVertices { .. } => "unreferenced-vertex reports",
            Defect::DegenerateFace { .. } => "degenerate faces",
            Defect::DuplicateFace { .. } => "duplicate faces",
            Defect::NonManifoldEdge { .. } => "non-manifold edges",
            Defect::NonManifoldVertex { .. } => "non-manifold vertices",
            Defect::InconsistentOrientation { .. } => "inconsistently oriented edges",
            Defect::Components { .. } => "component reports",
            Defect::NotDisk { .. } => "topology reports",
            Defect::NonFinitePosition { .. } => "non-finite vertices",
            Defect::CoordinateRange { .. } => "coordinate-range reports",
            Defect::Empty => "empty-mesh reports",
            Defect::NotPlanar { .. } => "planarity reports",
            Defect::ClockwiseFace { .. } => "clockwise faces",
            Defect::NoInterior => "interior reports",
        }
    }
}

/// One line per problem, at most `max_per_kind` of each kind followed by "... and N more `<kind>`".
/// Keeps messages readable for a mesh with thousands of bad faces.
pub(crate) fn summarize_problems(problems: &[Defect], max_per_kind: usize, sep: &str) -> String {
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
