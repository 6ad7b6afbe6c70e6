//! A run's `stop_reason` column: why its solver stopped, that it never started, or that it
//! failed. `skipped` is the harness's word, not a solver's: no solver returns it.

use serde::{de::Error, Deserialize, Deserializer, Serializer};
use solvers::solver::{StopReason, UnknownStopReason};

/// The `stop_reason` of a run that failed, in `summary.csv` and the history.
pub const FAILED_STOP: &str = "error";

/// The `stop_reason` of a pair outside the solver's definition (the reason in `error`,
/// `SolverEntry::skip_reason`).
pub const SKIPPED_STOP: &str = "skipped";

/// Why a run that did not fail ended: its solver's reason, or never started.
#[derive(Clone, Debug, PartialEq)]
pub enum RunStop {
    /// The solver ran and stopped for this reason.
    Solver(StopReason),
    /// Never started: the solver is not defined for the energy (or its parameters).
    Skipped,
}

impl RunStop {
    /// The column's text.
    pub fn as_str(&self) -> &'static str {
        match self {
            RunStop::Solver(r) => r.as_str(),
            RunStop::Skipped => SKIPPED_STOP,
        }
    }

    /// The solver's reason, `None` for a skipped pair.
    pub fn solver(&self) -> Option<&StopReason> {
        match self {
            RunStop::Solver(r) => Some(r),
            RunStop::Skipped => None,
        }
    }
}

impl From<StopReason> for RunStop {
    fn from(r: StopReason) -> RunStop {
        RunStop::Solver(r)
    }
}

impl std::str::FromStr for RunStop {
    type Err = UnknownStopReason;

    fn from_str(s: &str) -> Result<RunStop, UnknownStopReason> {
        if s == SKIPPED_STOP {
            Ok(RunStop::Skipped)
        } else {
            s.parse().map(RunStop::Solver)
        }
    }
}

/// The column's text of a run: its stop, or [`FAILED_STOP`] for a run that failed (`None`).
pub fn stop_text(stop: Option<&RunStop>) -> &'static str {
    stop.map_or(FAILED_STOP, RunStop::as_str)
}

/// A column's text as a run's stop: `None` for [`FAILED_STOP`].
pub fn parse_stop(text: &str) -> Result<Option<RunStop>, UnknownStopReason> {
    if text == FAILED_STOP {
        Ok(None)
    } else {
        text.parse().map(Some)
    }
}

/// `#[serde(with = ...)]` of the `stop_reason` column.
pub(crate) mod column {
    use super::*;

    pub fn serialize<S: Serializer>(v: &Option<RunStop>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(stop_text(v.as_ref()))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<RunStop>, D::Error> {
        parse_stop(&String::deserialize(d)?).map_err(D::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stop_round_trips_through_its_text_and_skipped_is_not_a_solver_reason() {
        let mut all: Vec<Option<RunStop>> = StopReason::ALL.into_iter().map(|r| Some(RunStop::Solver(r))).collect();
        all.extend([Some(RunStop::Skipped), None]);
        for stop in all {
            assert_eq!(parse_stop(stop_text(stop.as_ref())), Ok(stop.clone()));
        }
        assert!(SKIPPED_STOP.parse::<StopReason>().is_err());
        assert!(FAILED_STOP.parse::<StopReason>().is_err());
        assert_eq!(RunStop::Skipped.solver(), None);
        assert!(parse_stop("bored").is_err());
    }
}
