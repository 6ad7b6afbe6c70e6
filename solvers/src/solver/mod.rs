//! Solvers and what they report.
//!
//! A solver never prints and never touches files: it calls [`Observer::observe`] once per
//! iteration (row 0 is the initial state) and returns a [`Outcome`]. The harness owns I/O.

#[cfg(test)]
mod after_papers_tests;
pub mod aqp;
pub mod executor;
pub mod lbfgs;
pub mod map_iterate;
pub mod newton;
pub mod newton_system;
mod observer;
pub mod options;
mod outcome;
pub mod planar;
pub mod proxy;
mod settings;
mod stop;
pub mod truncated;

pub use crate::line_search::LineSearchSettings;
pub use newton::SolverSpec;
pub use newton::{newton, NewtonSettings};
#[cfg(test)]
pub(crate) use observer::TimeoutAt;
pub use observer::{Flow, IterationRecord, Metric, Observer, Recorder, StopAt, SystemView};
pub use options::RawOptions;
pub use outcome::{AnalysisReport, Outcome, SolveError, StartMap};
pub use settings::Settings;
pub use stop::{StopOverrides, StopReason, StopSettings, UnknownStopReason};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_reasons_round_trip_through_their_strings() {
        for r in StopReason::ALL {
            assert_eq!(r.as_str().parse::<StopReason>(), Ok(r.clone()));
            assert_eq!(r.to_string(), r.as_str());
            let de = serde::de::value::StrDeserializer::<serde::de::value::Error>::new(r.as_str());
            assert_eq!(<StopReason as serde::Deserialize>::deserialize(de), Ok(r.clone()));
        }
        let names: std::collections::BTreeSet<_> = StopReason::ALL.iter().map(|r| r.as_str()).collect();
        assert_eq!(names.len(), StopReason::ALL.len(), "one string per reason");
        // the detail travels in the error column, not in the reason
        assert_eq!("non_finite".parse(), Ok(StopReason::NonFinite(String::new())));
        assert_eq!(StopReason::LinearSolveFailed("pivot 3".into()).as_str(), "linear_solve_failed");
        let err = "converged".parse::<StopReason>().unwrap_err().to_string();
        assert!(err.starts_with("unknown stop reason 'converged' (known: grad_tol, "), "{err}");
        assert_eq!(StopReason::Timeout.as_str(), "timeout");
        assert!(!StopReason::Timeout.is_converged());
        assert!("skipped".parse::<StopReason>().is_err(), "skipped is the harness's word (no solver returns it)");
    }

    #[test]
    fn stop_rules_apply_in_order() {
        let s = StopSettings { grad_tol: 1e-3, energy_decrease_tol: 1e-6, max_iters: 10 };
        assert_eq!(s.reached(1e-4, 0.0, 99), Some(StopReason::GradientTolerance));
        assert_eq!(s.reached(1.0, 1e-7, 99), Some(StopReason::EnergyDecrease));
        assert_eq!(s.reached(1.0, f64::INFINITY, 10), Some(StopReason::MaxIterations));
        assert_eq!(s.reached(1.0, 1e-5, 9), None);
        // before the first step nothing has decreased: the decrease rule waits
        assert_eq!(StopSettings { energy_decrease_tol: 1e300, ..s }.reached(1.0, f64::INFINITY, 0), None);
        // a zero tolerance is no rule: neither a zero gradient nor a rise stops the run
        let off = StopSettings { grad_tol: 0.0, energy_decrease_tol: 0.0, max_iters: 10 };
        assert_eq!((off.reached(0.0, -1.0, 9), off.reached(0.0, -1.0, 10)), (None, Some(StopReason::MaxIterations)));
    }

    #[test]
    fn flows_map_to_their_stop_reasons() {
        assert_eq!(Flow::Continue.stop_reason(), None);
        assert_eq!(Flow::Stop.stop_reason(), Some(StopReason::Interrupted));
        assert_eq!(Flow::Timeout.stop_reason(), Some(StopReason::Timeout));
    }
}
