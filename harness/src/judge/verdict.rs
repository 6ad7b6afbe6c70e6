//! The harness's verdict on a finished run: solved when its final map is valid (no flipped
//! triangle) and within the tightest target, whatever its own stop rule said; otherwise why
//! not, in words a reader can act on.

// The verdict column's type is the summary's own, beside `Status`: `run_folder` types every file.
pub use crate::run_folder::summary::Verdict;

/// What the verdict is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facts {
    /// The final energy is within the tightest target.
    pub within: bool,
    /// Flipped triangles of the final map (a non-finite coordinate flips its faces).
    pub flips: usize,
    /// Its own stop rule said converged (gradient or energy-decrease tolerance).
    pub own_converged: bool,
    /// The final iterate's relative gap.
    pub final_gap: f64,
    /// The final gradient norm is within the run's `grad_tol`.
    pub small_gradient: bool,
    /// The gap a tight polish from the final map reached (`None`: not polished).
    pub polished_gap: Option<f64>,
    /// The loosest target: a gap above it is far from the reference.
    pub loosest: f64,
}

/// The verdict on a run of these facts.
pub fn judge(f: Facts) -> Verdict {
    if f.flips > 0 {
        return Verdict::Flipped;
    }
    if f.within {
        return Verdict::Solved;
    }
    // A NaN gap is far too.
    let far = |g: f64| g.partial_cmp(&f.loosest).is_none_or(|o| o.is_gt());
    // Another minimum is claimed only when a polish from the final map stays far too.
    if f.small_gradient && far(f.final_gap) && f.polished_gap.is_some_and(far) {
        Verdict::OtherMinimum
    } else if f.own_converged {
        Verdict::StoppedAboveTarget
    } else {
        Verdict::Unfinished
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts() -> Facts {
        Facts {
            within: true,
            flips: 0,
            own_converged: true,
            final_gap: 1e-9,
            small_gradient: true,
            polished_gap: None,
            loosest: 1e-3,
        }
    }

    #[test]
    fn each_verdict_from_its_facts() {
        assert_eq!(judge(facts()), Verdict::Solved);
        // whatever the solver's own rule said
        assert_eq!(judge(Facts { own_converged: false, small_gradient: false, ..facts() }), Verdict::Solved);
        // a flipped final map is never solved, within the target or not
        assert_eq!(judge(Facts { flips: 3, ..facts() }), Verdict::Flipped);
        assert_eq!(judge(Facts { flips: 1, within: false, final_gap: f64::INFINITY, ..facts() }), Verdict::Flipped);
        // |grad| <= 1e-3 but 1e-5 of the span above: stopped short
        let short = Facts { within: false, final_gap: 1e-5, ..facts() };
        assert_eq!(judge(short), Verdict::StoppedAboveTarget);
        // a small gradient 20% of the span above: another minimum only once a polish stays there
        let far = Facts { final_gap: 0.2, ..short };
        assert_eq!(judge(far), Verdict::StoppedAboveTarget);
        assert_eq!(judge(Facts { polished_gap: Some(0.19), ..far }), Verdict::OtherMinimum);
        assert_eq!(judge(Facts { polished_gap: Some(f64::INFINITY), ..far }), Verdict::OtherMinimum);
        // the polish went on down to the reference: not another minimum
        assert_eq!(judge(Facts { polished_gap: Some(1e-7), ..far }), Verdict::StoppedAboveTarget);
        assert_eq!(judge(Facts { polished_gap: Some(1e-7), own_converged: false, ..far }), Verdict::Unfinished);
        // the cap, a line search that gave up
        let capped = Facts { own_converged: false, small_gradient: false, ..short };
        assert_eq!(judge(capped), Verdict::Unfinished);
        // an energy-decrease stop with a large gradient above the target
        assert_eq!(judge(Facts { small_gradient: false, ..short }), Verdict::StoppedAboveTarget);
    }
}
