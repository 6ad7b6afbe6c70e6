//! The tasks (`param`, `deform`, `authalic`): one enum from the config to the CSV, and what
//! each refuses in a mesh.

use crate::mesh::topology;
use crate::mesh::{signed_area, validate, Defect, Mesh, ValidationReport};

/// The tasks of mapbench: what a config runs, what a mesh is validated for (each task's run
/// refuses exactly what [`validate_for`] reports for it) and which solvers run.
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
    /// Every task, in the book's order.
    pub const ALL: [Task; 3] = [Task::Param, Task::Deform, Task::Authalic];

    /// The task's name in configs, CSV and messages.
    pub fn as_str(&self) -> &'static str {
        match self {
            Task::Param => "param",
            Task::Deform => "deform",
            Task::Authalic => "authalic",
        }
    }
}

impl std::fmt::Display for Task {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
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

/// [`validate()`] with everything the run of `task` refuses in a mesh: `param` and `authalic`
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
                report.problems.push(Defect::NotPlanar { count: off.len(), first, z: mesh.positions[first][2] });
            } else if sound {
                // The orientation the solver sees: that of the normalized rest pose.
                let rest = mesh.normalized();
                let xy = |v: usize| [rest.positions[v][0], rest.positions[v][1]];
                report.problems.extend(
                    (0..rest.n_faces())
                        .filter(|&t| signed_area(rest.faces[t].map(xy)) <= 0.0)
                        .map(|face| Defect::ClockwiseFace { face }),
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
                    report.problems.push(Defect::NoInterior);
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
}
