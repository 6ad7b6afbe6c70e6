//! The harness's verdict on a finished run: solved when it passed the convergence test at the
//! tightest target with no flipped triangle, whatever its own stop rule said; otherwise why
//! not, in words a reader can act on.

// The verdict column's type is the summary's own, beside `Status`: `run_folder` types every file.
pub use crate::run_folder::summary::Verdict;

/// What the verdict is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facts {
    /// The run passed the tightest target at some iteration.
    pub reached: bool,
    /// Flipped triangles of the final map.
    pub flips: usize,
    /// Its own stop rule said converged (gradient or energy-decrease tolerance).
    pub own_converged: bool,
    /// The final iterate's relative gap.
    pub final_gap: f64,
    /// The final gradient norm is within the run's `grad_tol`.
    pub small_gradient: bool,
    /// The loosest target: a gap above it is far from the reference.
    pub loosest: f64,
}

/// The verdict on a run of these facts.
pub fn judge(f: Facts) -> Verdict {
    if f.reached {
        return if f.flips == 0 { Verdict::Solved } else { Verdict::Flipped };
    }
    // A NaN gap is far too.
    let far = f.final_gap.partial_cmp(&f.loosest).is_none_or(|o| o.is_gt());
    if f.small_gradient && far {
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
        Facts { reached: true, flips: 0, own_converged: true, final_gap: 1e-9, small_gradient: true, loosest: 1e-3 }
    }

    #[test]
    fn each_verdict_from_its_facts() {
        assert_eq!(judge(facts()), Verdict::Solved);
        // whatever the solver's own rule said
        assert_eq!(judge(Facts { own_converged: false, small_gradient: false, ..facts() }), Verdict::Solved);
        assert_eq!(judge(Facts { flips: 3, ..facts() }), Verdict::Flipped);
        // |grad| <= 1e-3 but 1e-5 of the way from the start: stopped short
        let short = Facts { reached: false, final_gap: 1e-5, ..facts() };
        assert_eq!(judge(short), Verdict::StoppedAboveTarget);
        // a small gradient 20% of the way above the reference: another minimum
        assert_eq!(judge(Facts { final_gap: 0.2, ..short }), Verdict::OtherMinimum);
        assert_eq!(judge(Facts { final_gap: f64::INFINITY, ..short }), Verdict::OtherMinimum);
        // the cap, a line search that gave up
        let capped = Facts { own_converged: false, small_gradient: false, ..short };
        assert_eq!(judge(capped), Verdict::Unfinished);
        // an energy-decrease stop with a large gradient above the target
        assert_eq!(judge(Facts { small_gradient: false, ..short }), Verdict::StoppedAboveTarget);
    }
}
