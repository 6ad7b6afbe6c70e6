//! The tasks (`param`, `deform`, `authalic`): one enum from the config to the CSV.

/// The tasks of mapbench: what a config runs, what a mesh is validated for (each task's run
/// refuses exactly what [`crate::mesh::validate_for`] reports for it) and which solvers run.
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
