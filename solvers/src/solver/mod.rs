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
pub use stop::{
    Events, RowState, RuleUse, Stall, StopOverrides, StopReason, StopRule, StopSettings, UnknownStopReason, GRAD_FLOOR,
    STALL_RTOL, STALL_WINDOW,
};

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
        assert!(!StopReason::Timeout.is_converged() && StopReason::Timeout.is_budget());
        assert!(StopReason::NoDecrease.is_stationary() && StopReason::GradientFloor.is_stationary());
        assert!(StopReason::LineSearchFailed.is_breakdown() && !StopReason::Target.is_converged());
        assert_eq!(StopRule::ALL.map(|r| r.as_str()), ["grad_tol", "energy_decrease"]);
        assert!("skipped".parse::<StopReason>().is_err(), "skipped is the harness's word (no solver returns it)");
    }

    /// A line search that finds no decrease: stationary where the full step's first-order
    /// decrease is within round-off of the energy (finger_1k's exp-SD minimum of the Newton
    /// methods: E = 674, steps lowering it by 1e-12), a breakdown where it is not.
    #[test]
    fn a_line_search_without_decrease_is_stationary_only_at_round_off() {
        let end = StopReason::after_line_search;
        assert_eq!(end(-5e-12, 674.03), StopReason::RoundOff);
        assert_eq!(end(-6.7e-10, 674.03), StopReason::RoundOff, "1e-12 of |E| and no more");
        assert_eq!(end(-7e-10, 674.03), StopReason::LineSearchFailed);
        assert_eq!(end(-1e-3, 2.6e11), StopReason::RoundOff, "relative to |E|");
        assert_eq!(end(-0.9e-12, 1e-3), StopReason::RoundOff, "relative to 1 below |E| = 1");
        assert_eq!(end(-1e-9, 1e-3), StopReason::LineSearchFailed);
        assert!(end(-1e-13, 1.0).is_stationary() && end(-1.0, 1.0).is_breakdown());
    }

    fn row(grad_norm: f64, last_decrease: f64, iter: usize) -> stop::RowState {
        stop::RowState { grad_norm, last_decrease, iter, at_target: false, stalled: false }
    }

    #[test]
    fn stop_rules_apply_in_order() {
        let s = StopSettings::rules_only(1e-3, 1e-6, 10);
        let end = |r: stop::RowState| s.end(&r, &Events::default());
        assert_eq!(end(row(1e-4, 0.0, 99)), Some(StopReason::GradientTolerance));
        assert_eq!(end(row(1.0, 1e-7, 99)), Some(StopReason::EnergyDecrease));
        assert_eq!(end(row(1.0, f64::INFINITY, 10)), Some(StopReason::MaxIterations));
        assert_eq!(end(row(1.0, 1e-5, 9)), None);
        // before the first step nothing has decreased: the decrease rule waits
        let huge = StopSettings { energy_decrease_tol: 1e300, ..s };
        assert_eq!(huge.end(&row(1.0, f64::INFINITY, 0), &Events::default()), None);
        // a zero tolerance is no rule: neither a zero gradient nor a rise stops the run
        let off = StopSettings::rules_only(0.0, 0.0, 10);
        let none = Events::default();
        assert_eq!(
            (off.end(&row(0.0, -1.0, 9), &none), off.end(&row(0.0, -1.0, 10), &none)),
            (None, Some(StopReason::MaxIterations))
        );
        assert_eq!(off.enabled().count(), 0);
    }

    /// Rules as events: a rule that holds ends nothing; the target ends the run once a rule
    /// that is on has held; the stationary ends come before the cap.
    #[test]
    fn rules_as_events_wait_for_the_target() {
        let s = StopSettings { rules: RuleUse::Event, grad_floor: 1e-10, ..StopSettings::rules_only(1e-3, 1e-6, 10) };
        let mut events = Events::default();
        let before = row(1e-2, 1.0, 2);
        s.mark(&before, &mut events);
        // at the target before any rule held: go on
        assert_eq!(s.end(&stop::RowState { at_target: true, ..before }, &events), None);
        let at = row(1e-4, 1.0, 3);
        s.mark(&at, &mut events);
        assert_eq!(events, Events { grad_tol: Some(3), energy_decrease: None });
        assert_eq!(s.end(&at, &events), None);
        // at the target once one rule held: the end (the other is not waited for)
        assert_eq!(s.end(&stop::RowState { at_target: true, ..at }, &events), Some(StopReason::Target));
        let later = row(1e-5, 1e-7, 5);
        s.mark(&later, &mut events);
        assert_eq!(events, Events { grad_tol: Some(3), energy_decrease: Some(5) });
        assert_eq!(events.first(), Some((StopRule::GradientTolerance, 3)));
        assert_eq!(s.end(&stop::RowState { at_target: true, ..later }, &events), Some(StopReason::Target));
        // the first iteration is kept
        s.mark(&row(1e-6, 1e-9, 6), &mut events);
        assert_eq!(events.grad_tol, Some(3));
        assert_eq!(s.end(&row(1e-11, 1.0, 6), &events), Some(StopReason::GradientFloor));
        assert_eq!(
            s.end(&stop::RowState { stalled: true, ..row(1e-5, 1.0, 10) }, &events),
            Some(StopReason::NoDecrease)
        );
        assert_eq!(s.end(&row(1e-5, 1.0, 10), &events), Some(StopReason::MaxIterations));
        // without rules the target ends the run at once
        let budget = StopSettings { rules: RuleUse::Event, ..StopSettings::rules_only(0.0, 0.0, 10) };
        let at_target = stop::RowState { at_target: true, ..row(1.0, 1.0, 0) };
        assert_eq!(budget.end(&at_target, &Events::default()), Some(StopReason::Target));
    }

    /// The stall: the lowest energy so far, over the window.
    #[test]
    fn a_stall_is_no_decrease_of_the_lowest_energy_over_the_window() {
        let mut stall = Stall::new(3);
        // a rise does not count as progress, nor does a return to the lowest
        let energies = [5.0, 4.0, 4.0, 6.0, 4.0, 4.0 - 1e-13, 3.0, 3.0, 3.0, 3.0];
        let stalled: Vec<bool> = energies.iter().map(|&e| stall.push(e)).collect();
        assert_eq!(stalled, [false, false, false, false, true, true, false, false, false, true]);
        let mut off = Stall::new(0);
        assert!((0..10).all(|_| !off.push(1.0)));
    }
    #[test]
    fn flows_map_to_their_stop_reasons() {
        assert_eq!(Flow::Continue.stop_reason(), None);
        assert_eq!(Flow::Stop.stop_reason(), Some(StopReason::Interrupted));
        assert_eq!(Flow::Timeout.stop_reason(), Some(StopReason::Timeout));
        assert_eq!(Flow::AtTarget.stop_reason(), None);
    }
}
