//! A run's time with its spread over the repeats (`time_s` and `time_s_min`..`time_s_max` of
//! `summary.csv`, `repeats` of them), and the values derived from it: what the report ranks
//! by and the gate compares.

use super::SummaryRow;

/// A time (or a time-derived value such as ms per vertex) with its spread over the repeats.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    /// The median over repeats (or a mean of medians).
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
    /// Repeats behind the value (the fewest of the runs it is made of); 1 = a single
    /// measurement, no spread; 0 = not a measurement (a cap, a constant).
    pub samples: usize,
}

impl Timed {
    /// `value`, a quantity proportional to `r.time_s` (time_s itself, ms per vertex,
    /// time_norm), with the run's min–max spread scaled alike. A run without a recorded
    /// spread counts as a single sample.
    pub fn of(r: &SummaryRow, value: f64) -> Timed {
        let single = Timed { value, lo: value, hi: value, samples: 1 };
        let (Some(t), Some(min), Some(max)) = (r.time_s, r.time_s_min, r.time_s_max) else { return single };
        let repeats = r.repeats.unwrap_or(1);
        // A spread is trusted when it comes from repeats and brackets the median.
        let spread = repeats > 1 && t > 0.0 && min <= t && t <= max;
        if !spread {
            return single;
        }
        let k = value / t;
        Timed { value, lo: min * k, hi: max * k, samples: repeats }
    }

    /// The run's `time_s` with its spread.
    pub fn time_s(r: &SummaryRow) -> Option<Timed> {
        r.time_s.map(|t| Timed::of(r, t))
    }

    /// A value that is not a measurement (a cap, a constant): no spread, and it does not make
    /// a combination with measured times single-sample.
    pub fn exact(value: f64) -> Timed {
        Timed { value, lo: value, hi: value, samples: 0 }
    }

    /// The mean of several times: each bound is the mean of the bounds (the mean of values
    /// that each lie in their interval lies in this one).
    pub fn mean(items: &[Timed]) -> Option<Timed> {
        Timed::combine(items, |v| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// `f` applied to the values, the lower and the upper bounds separately; `f` must be
    /// non-decreasing in every argument (a mean, a shifted geometric mean) for the result's
    /// bounds to bracket its value.
    pub fn combine(items: &[Timed], f: impl Fn(&[f64]) -> f64) -> Option<Timed> {
        if items.is_empty() {
            return None;
        }
        let pick = |g: fn(&Timed) -> f64| f(&items.iter().map(g).collect::<Vec<_>>());
        Some(Timed {
            value: pick(|t| t.value),
            lo: pick(|t| t.lo),
            hi: pick(|t| t.hi),
            // The fewest repeats of the measured parts (caps and constants have none).
            samples: items.iter().map(|t| t.samples).filter(|s| *s > 0).min().unwrap_or(0),
        })
    }

    /// No spread to show or to rank by: a single measurement, or no measurement at all.
    pub fn single_sample(&self) -> bool {
        self.samples <= 1
    }

    /// The two intervals share a point.
    pub fn overlaps(&self, other: &Timed) -> bool {
        self.lo <= other.hi && other.lo <= self.hi
    }

    /// `0.600` for a single sample, `0.600 (0.580–0.630)` with a spread, each number to
    /// [`TIME_DIGITS`] significant digits.
    pub fn text(&self) -> String {
        let f = |x: f64| significant(x, TIME_DIGITS);
        if self.single_sample() {
            f(self.value)
        } else {
            format!("{} ({}–{})", f(self.value), f(self.lo), f(self.hi))
        }
    }
}

/// The significant digits of every time the report and the gate print: enough to tell a 2%
/// change, few enough that `0.0213` and `213` read alike.
pub const TIME_DIGITS: usize = 3;

/// `x` to `digits` significant digits in positional notation: `0.0213`, `2.13`, `213`; a larger
/// number keeps its magnitude (`21300`), zero is `0`, and one below 1e-4 or from 1e7 on is
/// written in scientific notation (`2.53e-23`).
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if !(1e-4..1e7).contains(&x.abs()) {
        return format!("{:.*e}", digits.max(1) - 1, x);
    }
    // Round first, so 0.09996 becomes 0.100 and not 0.1000.
    let rounded: f64 = format!("{:.*e}", digits.max(1) - 1, x).parse().unwrap_or(x);
    let magnitude = rounded.abs().log10().floor() as i64;
    let decimals = (digits as i64 - 1 - magnitude).max(0) as usize;
    format!("{rounded:.decimals$}")
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::run_folder::Status;

    /// A summary row with a time and, optionally, its spread `(min, max, repeats)`.
    pub(crate) fn run(status: Status, t: f64, spread: Option<(f64, f64, usize)>) -> SummaryRow {
        SummaryRow {
            status,
            time_s: Some(t),
            time_s_min: spread.map(|s| s.0).or(Some(t)),
            time_s_max: spread.map(|s| s.1).or(Some(t)),
            repeats: spread.map(|s| s.2),
            ..Default::default()
        }
    }

    #[test]
    fn significant_digits_round_before_they_count() {
        let cases = [
            (0.021349, "0.0213"),
            (2.1349, "2.13"),
            (213.49, "213"),
            (21349.0, "21300"),
            (0.09996, "0.100"),
            (9.996, "10.0"),
            (-0.0004567, "-0.000457"),
            (0.0, "0"),
            (2.5299511e-23, "2.53e-23"),
            (0.00012345, "0.000123"),
            (12345678.0, "1.23e7"),
        ];
        for (x, want) in cases {
            assert_eq!(significant(x, 3), want, "{x}");
        }
        assert_eq!(significant(f64::NAN, 3), "NaN");
    }

    #[test]
    fn spreads_scale_with_derived_units_and_average() {
        let r = run(Status::Ok, 2.0, Some((1.0, 4.0, 3)));
        // ms per vertex of a 1000-vertex mesh: 2 ms, spread 1–4 ms.
        let t = Timed::of(&r, 2.0);
        assert_eq!((t.lo, t.hi, t.samples), (1.0, 4.0, 3));
        let half = Timed::of(&r, 1.0);
        assert!((half.lo - 0.5).abs() < 1e-12 && (half.hi - 2.0).abs() < 1e-12);
        assert_eq!(t.text(), "2.00 (1.00–4.00)");
        assert_eq!(Timed::exact(0.021349).text(), "0.0213");
        let m = Timed::mean(&[t, Timed::exact(4.0)]).unwrap();
        assert!((m.value - 3.0).abs() < 1e-12 && (m.lo - 2.5).abs() < 1e-12 && (m.hi - 4.0).abs() < 1e-12);
        assert_eq!(m.samples, 3, "a cap is not a measurement: the measured part's repeats count");
        let m = Timed::mean(&[t, Timed::of(&run(Status::Ok, 4.0, None), 4.0)]).unwrap();
        assert!(m.single_sample(), "a mean with a single-sample part is single-sample");
        assert!(Timed::mean(&[Timed::exact(1.0)]).unwrap().single_sample());
        assert_eq!(Timed::mean(&[]), None);
        // A spread that does not contain the median is not trusted.
        let bad = run(Status::Ok, 2.0, Some((2.5, 3.0, 3)));
        assert!(Timed::time_s(&bad).unwrap().single_sample());
    }
}
