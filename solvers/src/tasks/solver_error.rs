//! Why a solver of the catalogue cannot run as asked.

use crate::tasks::task::Task;

/// Why a solver cannot run as asked.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SolverError {
    /// No solver has this name.
    #[error("unknown {}solver '{name}' (known: {})", task_qualifier(*task), known.join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The task it was asked for.
        task: Task,
        /// The names of that task's solvers.
        known: Vec<&'static str>,
    },
    /// The solver does not run this task.
    #[error(
        "'{name}' is {} solver: task {task} runs {} only",
        kind_of(runs),
        known.join(", ")
    )]
    WrongTask {
        /// The solver's name.
        name: &'static str,
        /// The tasks it runs.
        runs: &'static [Task],
        /// The task asked for.
        task: Task,
        /// The names of that task's solvers.
        known: Vec<&'static str>,
    },
    /// The solver is not defined for this energy (or these parameters), with the reason.
    #[error("{0}")]
    Unsupported(String),
    /// The solver runs the task without a Newton system (nothing to build or export).
    #[error("'{name}' has no Newton system ({description})")]
    NoSystem {
        /// The solver's name.
        name: &'static str,
        /// Its catalogue description.
        description: &'static str,
    },
    /// Its `[solver.<name>]` table does not read as its options.
    #[error("[solver.{name}] {message}")]
    Options {
        /// The solver's name.
        name: &'static str,
        /// Why the table does not read.
        message: String,
    },
}

/// "authalic " in "unknown authalic solver": the Newton-type solvers are the unqualified ones.
fn task_qualifier(task: Task) -> &'static str {
    match task {
        Task::Param | Task::Deform => "",
        Task::Authalic => "authalic ",
    }
}

/// "an authalic", "a param/deform".
fn kind_of(tasks: &[Task]) -> String {
    let tasks: Vec<&str> = tasks.iter().map(|t| t.as_str()).collect();
    let tasks = tasks.join("/");
    let article = if tasks.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} {tasks}")
}
