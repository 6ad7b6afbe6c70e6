//! The convergence test of Moré and Wild ("Benchmarking derivative-free optimization
//! algorithms", SIAM J. Optim. 2009, Eq. 2.2): a run solves its problem at tolerance `tau` at
//! the first iteration where `E0 - E >= (1 - tau) (E0 - E*)`, with `E0` the start's energy and
//! `E*` a reference minimum. The benchmark decides, not the solver's own stop rule, so runs
//! that stop by different rules are compared at the same accuracy.
//!
//! A `deform` start carries the handles' penalty (`lambda = 1e5` against an elastic energy
//! of order 1), so `E0 - E*` would make every target loose by the penalty's size. There the span is at most the shape's own change,
//! `(E* - E_rest) + (E_start - E_rest)` with `E_rest` and `E_start` the elastic energies
//! (penalty left out) at the rest pose and at the start ([`judged_start`]).

/// The relative gap `(E - E*) / (E0 - E*)` of energy `e`: 1 at the start, 0 at the reference
/// minimum, negative below it. A start at (or below) the reference has gap 0 where `e` is
/// not above the start and +inf where it is; a non-finite `e` has gap +inf.
pub fn gap(e: f64, e0: f64, e_star: f64) -> f64 {
    gap_on(e, e_star, e0 - e_star)
}

/// [`gap`] on a given span `E0 - E*` (`summary.csv`'s `gap_scale`).
pub fn gap_on(e: f64, e_star: f64, span: f64) -> f64 {
    if !e.is_finite() {
        return f64::INFINITY;
    }
    if span > 0.0 && span.is_finite() {
        (e - e_star) / span
    } else if e - e_star <= span {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Whether energy `e` passes the test at tolerance `tau` (Moré and Wild's form: no division,
/// so a start at the reference passes at once).
pub fn passes(e: f64, e0: f64, e_star: f64, tau: f64) -> bool {
    e.is_finite() && e0 - e >= (1.0 - tau) * (e0 - e_star)
}

/// The first row of `energies` (row 0 = the start) that passes the test at `tau` against
/// `e_star` with the start energy `e0` ([`judged_start`]); `None` when no row does.
pub fn first_reached(energies: &[f64], e0: f64, e_star: f64, tau: f64) -> Option<usize> {
    energies.iter().position(|&e| passes(e, e0, e_star, tau))
}

/// The start energy the test measures from: the run's `e0`, or `e_star + scale` when a
/// problem scale (`deform`'s elastic change) is positive and smaller than `e0 - e_star`.
/// Without a smaller scale it is `e0` itself, bit for bit.
pub fn judged_start(e0: f64, e_star: f64, scale: Option<f64>) -> f64 {
    match scale {
        Some(s) if s > 0.0 && s.is_finite() && s < e0 - e_star => e_star + s,
        _ => e0,
    }
}

/// `deform`'s scale: `(E* - E_rest) + (E_start - E_rest)`, how far the minimum and the start
/// are from the rest pose in elastic energy (the rest pose, an isometry, is the elastic
/// energy's minimum). `None` when it is not positive (a problem whose minimum and start are
/// the rest pose: then `E0 - E*` is the span).
pub fn elastic_scale(e_star: f64, rest: f64, start: f64) -> Option<f64> {
    let s = (e_star - rest) + (start - rest);
    (s > 0.0 && s.is_finite()).then_some(s)
}

/// The time a run took to reach row `k`: its whole time `time_s` (setup included) less what
/// its iterations after row `k` took (`t_cum[k]` is the cumulative iteration time at row `k`).
pub fn time_to(time_s: f64, t_cum: &[f64], k: usize) -> Option<f64> {
    let (at, last) = (*t_cum.get(k)?, *t_cum.last()?);
    Some((time_s - (last - at)).max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_test_passes_at_the_first_row_within_the_tolerance() {
        // E0 = 10, E* = 2: tau 1e-1 needs E <= 2.8, tau 1e-3 needs E <= 2.008.
        let e = [10.0, 5.0, 2.9, 2.7, 2.01, 2.0079, 2.0];
        assert_eq!(first_reached(&e, 10.0, 2.0, 1e-1), Some(3));
        assert_eq!(first_reached(&e, 10.0, 2.0, 1e-3), Some(5));
        assert_eq!(first_reached(&e, 10.0, 2.0, 0.0), Some(6));
        // never reached: stopped at 2.01
        assert_eq!(first_reached(&e[..5], 10.0, 2.0, 1e-3), None);
        assert_eq!(first_reached(&[], 10.0, 2.0, 1e-3), None);
        // the gap of each row
        assert_eq!(gap(10.0, 10.0, 2.0), 1.0);
        assert_eq!(gap(2.0, 10.0, 2.0), 0.0);
        assert!((gap(2.8, 10.0, 2.0) - 0.1).abs() < 1e-15);
        // a NaN row never passes, and does not hide a later one
        assert_eq!(first_reached(&[10.0, f64::NAN, 2.0], 10.0, 2.0, 1e-6), Some(2));
        assert_eq!(gap(f64::NAN, 10.0, 2.0), f64::INFINITY);
    }

    #[test]
    fn a_reference_lowered_by_a_run_moves_every_verdict() {
        // Against E* = 2 (E0 = 10) the run ending at 2.0005 has gap 0.0005 / 8 and solves
        // 1e-3 at row 2; a run of the batch that ends at 1.5 lowers E*, and its gap becomes
        // (2.0005 - 1.5) / 8.5 = 0.059: not solved.
        let e = [10.0, 4.0, 2.0005];
        assert_eq!(first_reached(&e, 10.0, 2.0, 1e-3), Some(2));
        assert_eq!(first_reached(&e, 10.0, 1.5, 1e-3), None);
        assert!((gap(2.0005, 10.0, 1.5) - 0.5005 / 8.5).abs() < 1e-15);
        // the run that lowered it is at gap 0
        assert_eq!(first_reached(&[10.0, 1.5], 10.0, 1.5, 0.0), Some(1));
        // below the reference the gap is negative, and the test passes
        assert!(gap(1.9, 10.0, 2.0) < 0.0 && passes(1.9, 10.0, 2.0, 0.0));
    }

    #[test]
    fn a_start_at_the_reference_passes_at_once() {
        assert_eq!(first_reached(&[2.0, 2.0], 2.0, 2.0, 1e-6), Some(0));
        assert_eq!(gap(2.0, 2.0, 2.0), 0.0);
        assert_eq!(gap(3.0, 2.0, 2.0), f64::INFINITY);
    }

    /// A `deform` start dominated by the penalty (E0 = 1.9e5, E* = 2.21, an SD rest pose of
    /// 2): measured from `E0`, a run 0.1 above `E*` passes 1e-6; measured on the shape's
    /// change (0.21) it needs to be within 2.1e-7. A start whose elastic change is the whole
    /// span (the released bar) or none keeps `E0` bit for bit.
    #[test]
    fn a_deform_start_is_judged_on_the_shape_s_own_change() {
        let (e0, e_star) = (1.9e5, 2.21);
        let scale = elastic_scale(e_star, 2.0, 2.0);
        assert!((scale.unwrap() - 0.21).abs() < 1e-15);
        let start = judged_start(e0, e_star, scale);
        assert_eq!(start, e_star + scale.unwrap());
        let run = [e0, 1e3, e_star + 0.1, e_star + 1e-7];
        assert_eq!(first_reached(&run, e0, e_star, 1e-6), Some(2));
        assert_eq!(first_reached(&run, start, e_star, 1e-6), Some(3));
        assert!((gap(e_star + 0.1, start, e_star) - 0.1 / 0.21).abs() < 1e-12);
        // the released bar: its start's elastic energy is the span, E0 stays
        let (e0, e_star, rest) = (0.2013, 0.2, 0.2);
        assert_eq!(judged_start(e0, e_star, elastic_scale(e_star, rest, e0)), e0);
        // minimum and start at the rest pose: no scale
        assert_eq!(elastic_scale(2.0, 2.0, 2.0), None);
        assert_eq!(judged_start(5.0, 2.0, None), 5.0);
        assert_eq!(judged_start(5.0, 2.0, Some(f64::NAN)), 5.0);
    }

    #[test]
    fn time_to_a_row_leaves_out_the_iterations_after_it() {
        // setup 0.5 s, then iterations of 1, 2 and 3 s: 6.5 s in all
        let t_cum = [0.0, 1.0, 3.0, 6.0];
        assert_eq!(time_to(6.5, &t_cum, 3), Some(6.5));
        assert_eq!(time_to(6.5, &t_cum, 1), Some(1.5));
        assert_eq!(time_to(6.5, &t_cum, 0), Some(0.5));
        assert_eq!(time_to(6.5, &t_cum, 4), None);
    }
}
