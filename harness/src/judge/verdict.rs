//! The harness's verdict on a finished run: solved when its final map is valid (no flipped
//! triangle) and within the tightest target, whatever its own stop rule said; otherwise why
//! not, in words a reader can act on, from how the run ended ([`End`]).

// The verdict column's type is the summary's own, beside `Status`: `run_folder` types every file.
pub use crate::run_folder::summary::Verdict;
use solvers::solver::StopReason;

/// How a run ended, as the verdict reads its stop reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// A stop rule ended it: a tolerance rule where rules end runs (a group without a
    /// reference), an external solver's own rule.
    Rule,
    /// At the target of the reference the run started with.
    Target,
    /// The gradient floor, no decrease beyond round-off over the stall window, or a line
    /// search at round-off (`round_off`).
    Stationary,
    /// The method broke down (`StopReason::is_breakdown`).
    Breakdown,
    /// The iteration cap or the time limit (or an interrupt, which is no result).
    Budget,
}

impl End {
    /// The end of a run that stopped for `reason`.
    pub fn of(reason: &StopReason) -> End {
        match reason {
            StopReason::Target => End::Target,
            r if r.is_converged() => End::Rule,
            r if r.is_stationary() => End::Stationary,
            r if r.is_breakdown() => End::Breakdown,
            _ => End::Budget,
        }
    }
}

/// What the verdict is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facts {
    /// The final energy is within the tightest target.
    pub within: bool,
    /// Flipped triangles of the final map (a non-finite coordinate flips its faces).
    pub flips: usize,
    /// How the run ended.
    pub end: End,
    /// The final iterate's relative gap.
    pub final_gap: f64,
    /// The final gradient norm is within the run's `grad_tol`.
    pub small_gradient: bool,
    /// The gap a tight polish from the final map reached (`None`: not polished).
    pub polished_gap: Option<f64>,
    /// The tightest target, the one the run is judged at: a gap above it is far from the
    /// reference.
    pub tightest: f64,
}

/// The most of its gap a polish may close and still count as staying at the run's minimum:
/// at another local minimum a Newton polish moves by round-off (at most 2e-4 of the gap on the
/// default nightly), in a slow valley it goes on down (2% to 99% in its 100 iterations).
pub const STAYED: f64 = 1e-3;

/// The verdict on a run of these facts.
pub fn judge(f: Facts) -> Verdict {
    if f.flips > 0 {
        return Verdict::Flipped;
    }
    if f.within {
        return Verdict::Solved;
    }
    // A NaN gap is far too.
    let far = |g: f64| g.partial_cmp(&f.tightest).is_none_or(|o| o.is_gt());
    // Another minimum is claimed only when a polish from the final map stays: far too, and
    // having closed no more than round-off of the gap.
    let settled = f.small_gradient || f.end == End::Stationary;
    let stayed = |p: f64| far(p) && p >= (1.0 - STAYED) * f.final_gap;
    if settled && far(f.final_gap) && f.polished_gap.is_some_and(stayed) {
        return Verdict::OtherMinimum;
    }
    match f.end {
        End::Rule | End::Target => Verdict::StoppedAboveTarget,
        End::Stationary => Verdict::Stalled,
        End::Breakdown => Verdict::BrokeDown,
        End::Budget => Verdict::Unfinished,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts() -> Facts {
        Facts {
            within: true,
            flips: 0,
            end: End::Target,
            final_gap: 1e-9,
            small_gradient: true,
            polished_gap: None,
            tightest: 1e-6,
        }
    }

    #[test]
    fn each_end_reads_as_its_stop_reasons() {
        let ends = StopReason::ALL.map(|r| (r.as_str(), End::of(&r)));
        let of = |name: &str| ends.iter().find(|(n, _)| *n == name).map(|e| e.1);
        for (name, end) in [
            ("grad_tol", End::Rule),
            ("energy_decrease", End::Rule),
            ("solver_rule", End::Rule),
            ("target", End::Target),
            ("grad_floor", End::Stationary),
            ("no_decrease", End::Stationary),
            ("round_off", End::Stationary),
            ("line_search_failed", End::Breakdown),
            ("linear_solve_failed", End::Breakdown),
            ("not_descent", End::Breakdown),
            ("non_finite", End::Breakdown),
            ("energy_increased", End::Breakdown),
            ("max_iters", End::Budget),
            ("timeout", End::Budget),
        ] {
            assert_eq!(of(name), Some(end), "{name}");
        }
    }

    #[test]
    fn each_verdict_from_its_facts() {
        assert_eq!(judge(facts()), Verdict::Solved);
        // whatever the run's end
        assert_eq!(judge(Facts { end: End::Budget, small_gradient: false, ..facts() }), Verdict::Solved);
        // a flipped final map is never solved, within the target or not
        assert_eq!(judge(Facts { flips: 3, ..facts() }), Verdict::Flipped);
        assert_eq!(judge(Facts { flips: 1, within: false, final_gap: f64::INFINITY, ..facts() }), Verdict::Flipped);
        // each end above the target, 1e-5 of the span above
        let short = Facts { within: false, final_gap: 1e-5, small_gradient: false, ..facts() };
        assert_eq!(judge(Facts { end: End::Rule, ..short }), Verdict::StoppedAboveTarget);
        assert_eq!(judge(Facts { end: End::Target, ..short }), Verdict::StoppedAboveTarget);
        assert_eq!(judge(Facts { end: End::Stationary, ..short }), Verdict::Stalled);
        assert_eq!(judge(Facts { end: End::Breakdown, ..short }), Verdict::BrokeDown);
        assert_eq!(judge(Facts { end: End::Budget, ..short }), Verdict::Unfinished);
        // 20% of the span above: another minimum only once a polish stays there, and only for
        // a run that settled (stationary, or a small gradient)
        let far = Facts { final_gap: 0.2, end: End::Stationary, ..short };
        assert_eq!(judge(far), Verdict::Stalled);
        assert_eq!(judge(Facts { polished_gap: Some(0.1999), ..far }), Verdict::OtherMinimum);
        assert_eq!(judge(Facts { polished_gap: Some(f64::INFINITY), ..far }), Verdict::OtherMinimum);
        // a polish that closed more than round-off of the gap found the run in a slow valley
        // (sack_1k's BARAP: kp-newton's 1000 iterations 5.6e-6 above, the polish 2% lower)
        assert_eq!(judge(Facts { polished_gap: Some(0.19), ..far }), Verdict::Stalled);
        assert_eq!(judge(Facts { polished_gap: Some(0.2 * (1.0 - STAYED)), ..far }), Verdict::OtherMinimum);
        // an infinite gap (a zero span) stays only where the polish's is infinite too
        let endless = Facts { final_gap: f64::INFINITY, ..far };
        assert_eq!(judge(Facts { polished_gap: Some(1e3), ..endless }), Verdict::Stalled);
        let capped = Facts { end: End::Budget, polished_gap: Some(0.1999), ..far };
        assert_eq!(judge(capped), Verdict::Unfinished);
        assert_eq!(judge(Facts { small_gradient: true, ..capped }), Verdict::OtherMinimum);
        let crawling = Facts { small_gradient: true, polished_gap: Some(5.52e-6), final_gap: 5.63e-6, ..capped };
        assert_eq!(judge(crawling), Verdict::Unfinished);
        // the polish went on down to the reference: not another minimum
        assert_eq!(judge(Facts { polished_gap: Some(1e-7), ..far }), Verdict::Stalled);
        // far is past the tightest target, the one the run is judged at: a minimum 1e-4 of the
        // span above E* that the polish stays at is another one (the Newton methods' exp-SD
        // minima on finger_1k, 8.7e-4 above), one the polish leaves to pass 1e-6 is not
        let near = Facts { final_gap: 1e-4, ..far };
        assert_eq!(judge(Facts { polished_gap: Some(1e-4), ..near }), Verdict::OtherMinimum);
        assert_eq!(judge(Facts { polished_gap: Some(0.9e-6), ..near }), Verdict::Stalled);
        // a breakdown is not settled, however close
        assert_eq!(judge(Facts { end: End::Breakdown, polished_gap: Some(1e-4), ..near }), Verdict::BrokeDown);
    }
}
