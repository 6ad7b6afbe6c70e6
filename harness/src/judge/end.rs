//! Where a run ends: at its group's tightest target, known before any run from the reference
//! minimum (docs/src/design/numerics.md, "Runs go to the target"). The solver's tolerance rules
//! are then events; a run without a target (no reference, or a fixed-budget protocol, which
//! runs its budget) is ended by its rules as the papers' protocol ends it.

use super::reference::GroupReference;
use super::Yardstick;
use crate::plan::{Plan, PlannedRun};

/// The target a run goes to: the first row that passes its group's tightest target with no
/// flipped triangle ends it (once its rules have held).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetEnd {
    pub stick: Yardstick,
    /// The tightest target of the run's energy.
    pub tau: f64,
}

impl TargetEnd {
    /// The target of `run` against its group's reference in `references`; `None` without a
    /// reference (its rules end it) and for a fixed-budget protocol (no tolerance rule: it
    /// runs its budget, whose final values the tables compare).
    pub fn of(plan: &Plan, run: &PlannedRun, references: &[GroupReference]) -> Option<TargetEnd> {
        if run.settings.stop().is_fixed_budget() {
            return None;
        }
        let dataset = &plan.dataset(run).name;
        let group = references.iter().find(|g| &g.dataset == dataset && g.energy == run.energy)?;
        let stick = Yardstick::of(group)?;
        let tau = plan.targets.tightest(&run.energy)?;
        Some(TargetEnd { stick, tau })
    }

    /// Whether a row of energy `e` and `flips` flipped triangles is at the target, in a run
    /// whose row 0 has energy `run_e0`.
    pub fn reached(&self, e: f64, flips: usize, run_e0: f64) -> bool {
        flips == 0 && self.stick.passes(e, run_e0, self.tau)
    }

    /// The energy at or below which a row of a run from the common start passes the test at
    /// `tau` (`None` in a folder's group without the common start's energy).
    pub fn energy_at(&self, tau: f64) -> Option<f64> {
        let e0 = self.stick.e0?;
        let e_star = self.stick.e_star;
        Some(e_star + (tau * self.stick.span(e0)).max(crate::convergence::ROUNDOFF * e_star.abs().max(1.0)))
    }

    /// What determines where the run ends, for its `--resume` key: the reference and the
    /// target, bit for bit.
    pub fn key_text(&self) -> String {
        let bits = |v: Option<f64>| v.map_or(String::from("-"), |v| format!("{:016x}", v.to_bits()));
        format!(
            "target e*={} e0={} ideal={} tau={}",
            bits(Some(self.stick.e_star)),
            bits(self.stick.e0),
            bits(self.stick.ideal),
            bits(Some(self.tau))
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::summary::RefSource;

    fn end(e0: Option<f64>) -> TargetEnd {
        let stick = Yardstick { e_star: 2.0, source: RefSource::Reference, certified: true, e0, ideal: Some(1.0) };
        TargetEnd { stick, tau: 1e-6 }
    }

    /// E* = 2, E_iso = 1, E0 = 10: the span is min(8, 1) = 1, the target 2 + 1e-6.
    #[test]
    fn a_row_is_at_the_target_within_tau_of_the_span_with_no_flips() {
        let t = end(Some(10.0));
        assert!(t.reached(2.0 + 0.9e-6, 0, 50.0) && !t.reached(2.0 + 1.1e-6, 0, 50.0));
        assert!(!t.reached(2.0, 1, 10.0), "a flipped row is not at the target");
        // a folder's group without E0 takes the run's own row 0: span min(2.5, 1)
        assert!(end(None).reached(2.0 + 0.9e-6, 0, 4.5));
        assert!(!end(None).reached(2.0 + 0.9e-6, 0, 2.0 + 0.5e-6), "span 0.5e-6: within round-off only");
        assert_ne!(end(Some(10.0)).key_text(), end(None).key_text());
        assert_eq!(end(Some(10.0)).energy_at(1e-3), Some(2.001));
        assert_eq!(end(Some(2.0)).energy_at(1e-3), Some(2.0 + 2e-12), "a start at E*: round-off");
        assert_eq!(end(None).energy_at(1e-3), None);
        assert_ne!(end(Some(10.0)).key_text(), TargetEnd { tau: 1e-3, ..end(Some(10.0)) }.key_text());
    }
}
