//! The timing section: repeats, machine calibration and its spread warning.

use crate::calibration::SPREAD_WARNING;
use crate::escape::esc;
use crate::report::batch::Batch;
use crate::run_folder::SummaryRow;
use std::fmt::Write as _;

/// How the times were taken: the repeats, the machine calibration of `meta.json` and, when
/// its spread exceeds [`SPREAD_WARNING`], a visible warning.
pub(super) fn timing_section(h: &mut String, summaries: &[SummaryRow], batch: &Batch) {
    let repeats = summaries.iter().filter_map(|s| s.repeats).max().unwrap_or(1);
    let ran = summaries.iter().filter(|s| s.status.ran()).count();
    let repeated = summaries.iter().filter(|s| s.status.ran() && s.repeats.is_some_and(|r| r > 1)).count();
    let mut p = if repeats > 1 {
        format!(
            "{repeated} of the {ran} runs were repeated {repeats} times, round-robin over the plan: those whose \
             times decide a ranking, the runs that reached their target (or ran a fixed budget) in at most {} \
             times the fastest such run of their problem; times are the median over the repeats, with their \
             min–max in parentheses, and ranked times tie when these intervals overlap. The others were timed \
             once: a run far slower than the fastest cannot tie with it within the machine's noise, and a run \
             that stalled, broke down or ran out of budget counts at the cap.",
            crate::run::REPEAT_WITHIN
        )
    } else {
        "Each run was timed once (repeat = 1): times are single samples, so rankings cannot tell \
         differences within the machine's noise (marked † in the tables)."
            .to_string()
    };
    let calibration = batch.calibration.as_ref().and_then(|c| Some((c, c.median_s()?, c.spread()?)));
    match calibration {
        Some((c, median, spread)) => {
            let _ = write!(
                p,
                " Machine calibration ({}): median {} over {} samples, spread {:.1}% ((max − min) / median); \
                 time_norm = time_s / {}.",
                c.workload,
                seconds(median),
                c.samples_s.len(),
                100.0 * spread,
                seconds(median)
            );
        }
        None => p += " No machine calibration in meta.json: times are not normalized (time_norm empty).",
    }
    let _ = writeln!(h, "<p class=\"caption\" id=\"timing\">{}</p>", esc(&p));
    if let Some((c, _, spread)) = calibration.filter(|(c, _, _)| c.unsteady()) {
        let _ = writeln!(
            h,
            "<p class=\"warn\"><b>Warning: the machine changed speed during this batch.</b> The calibration \
             samples ({}) spread by {:.1}%, more than {:.0}%: times of runs taken at different moments \
             differ by more than their repeats show, and time rankings are less certain.</p>",
            esc(&c.samples_s.iter().map(|t| seconds(*t)).collect::<Vec<_>>().join(", ")),
            100.0 * spread,
            100.0 * SPREAD_WARNING
        );
    }
}

/// Seconds with 3 significant digits (0.0431 s, 6.59 s, 123 s).
pub(super) fn seconds(t: f64) -> String {
    format!("{} s", significant(t))
}

/// 3 significant digits (0.0431, 6.59, 123), as every time of the report.
pub(super) fn significant(t: f64) -> String {
    crate::run_folder::timed::significant(t, crate::run_folder::timed::TIME_DIGITS)
}

/// 2 significant digits in at most 7 characters, for the status cells (0.0043, 0.21, 6.6, 12,
/// 123; 4e-5 below a millisecond).
pub(super) fn brief(t: f64) -> String {
    if t > 0.0 && t < 1e-3 {
        return format!("{t:.0e}");
    }
    let digits = if t <= 0.0 { 2 } else { (1 - t.abs().log10().floor() as i64).clamp(0, 6) as usize };
    format!("{t:.digits$}")
}
