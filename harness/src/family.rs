//! The class of method each catalogue solver is: how it treats the Hessian. A harness
//! concept, not a numerical one: the report draws a family in related hues
//! (`report::plots::colors`), the Slurm planner starts its cost estimates from it
//! (`slurm::costs`) and the book's solvers page groups by it. A solver the table does not
//! name (an external one, or a catalogue entry not yet given a family) has none: the
//! report draws it in the external solvers' hue and the planner guesses its cost high.

/// A class of method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Family {
    /// Newton with the element Hessians projected analytically (the complex-view paper).
    AnalyticNewton,
    /// Newton with the element Hessians projected or filtered numerically, per element.
    NumericNewton,
    /// Newton on filtered or unmodified Hessians (eigenvalue filtering, plain Newton).
    FilteredNewton,
    /// A proxy or majorizer as the system matrix (CM, SLIM, AKVF, AQP).
    Proxy,
    /// Quasi-Newton (L-BFGS).
    QuasiNewton,
    /// The authalic solvers.
    Authalic,
}

impl Family {
    /// What the book's solvers page calls it.
    pub fn label(self) -> &'static str {
        match self {
            Family::AnalyticNewton => "analytic Newton",
            Family::NumericNewton => "numeric projection",
            Family::FilteredNewton => "filtered Newton",
            Family::Proxy => "proxy",
            Family::QuasiNewton => "quasi-Newton",
            Family::Authalic => "authalic",
        }
    }
}

/// The catalogue's solvers by family (a test checks every catalogue name is here once).
const MEMBERS: [(Family, &[&str]); 6] = [
    (
        Family::AnalyticNewton,
        &["kp-newton", "kp-newton-cg", "kp-newton-cg-laplacian", "kp-newton-noscale", "kp-newton-eig8"],
    ),
    (Family::NumericNewton, &["fp-newton-4x4", "fp-newton-6x6", "fp-abs-6x6", "fp-trust-region-6x6"]),
    (Family::FilteredNewton, &["newton", "pn-abs", "pn-trust-region"]),
    (Family::Proxy, &["cm", "slim", "akvf", "aqp"]),
    (Family::QuasiNewton, &["lbfgs", "lbfgs-laplacian"]),
    (Family::Authalic, &["sem", "aem-cg", "aem-cg-safe"]),
];

/// The family of the catalogue solver `name`; none for any other name.
pub fn family(name: &str) -> Option<Family> {
    MEMBERS.iter().find(|(_, names)| names.contains(&name)).map(|(f, _)| *f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use solvers::tasks::catalogue::SOLVERS;

    #[test]
    fn every_catalogue_solver_has_one_family_and_every_member_is_in_the_catalogue() {
        for s in SOLVERS {
            let n = MEMBERS.iter().filter(|(_, names)| names.contains(&s.name)).count();
            assert_eq!(n, 1, "{}: give it one family in harness/src/family.rs", s.name);
        }
        for (_, names) in MEMBERS {
            for name in names {
                assert!(solvers::tasks::catalogue::find(name).is_some(), "{name} is not in the catalogue");
            }
        }
        assert_eq!(family("sem"), Some(Family::Authalic));
        assert_eq!(family("my-peer"), None);
    }
}
