//! Convergence curves of one (dataset, energy) group: the gap vs iteration and vs time,
//! #negative eigenvalues vs iteration (the complex-view paper's Figures 2-3). A judged group's
//! gap is the verdict's, `(E - E*) / span` against the judge's `E*`, with the targets drawn:
//! one yardstick on the page.

use super::chart::{self, draw_series, format_count, format_linear, house_style, render_framed, Curve, Series, XAxis};
use super::plot::{Plot, PlotKind};
use crate::report::select::converged;
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use plotters::prelude::*;
use rayon::prelude::*;
use std::path::Path;

/// The three curve plots of a group's finished `runs`, written under `run_dir`.
pub(super) fn render_group(
    run_dir: &Path,
    (dataset, energy): (&str, &str),
    runs: &[&SummaryRow],
    solvers: &[&str],
) -> Result<Vec<Plot>> {
    // The group's yardstick when every run has it (they share E* and the span).
    let yardstick = runs.first().and_then(|r| r.ref_energy.zip(r.gap_scale));
    let judged = yardstick.is_some() && runs.iter().all(|r| r.ref_energy.zip(r.gap_scale) == yardstick);
    let yardstick = yardstick.filter(|_| judged);
    let targets: Vec<f64> = match yardstick {
        Some(_) => runs.first().map(|r| r.to_targets.iter().map(|t| t.tau).collect()).unwrap_or_default(),
        None => Vec::new(),
    };
    let certified = runs.first().and_then(|r| r.ref_certified);
    let curves = runs
        .par_iter()
        .map(|r| {
            let curve = Curve::new(crate::run_folder::read_run(run_dir, r)?, yardstick);
            Ok(Series { solver: &r.solver, style: chart::style(solvers, &r.solver), converged: converged(r), curve })
        })
        .collect::<Result<Vec<_>>>()?;
    let gap = Gap { judged: yardstick.is_some(), targets: &targets, certified };
    let kinds = [PlotKind::EnergyIter, PlotKind::EnergyTime, PlotKind::NegEigIter];
    kinds
        .into_par_iter()
        .map(|kind| {
            let (suffix, what) = match kind {
                PlotKind::EnergyIter => ("energy_iter", "gap vs iteration"),
                PlotKind::EnergyTime => ("energy_time", "gap vs time"),
                _ => ("neg_eig_iter", "#negative eigenvalues vs iteration"),
            };
            let file = format!("plots/{dataset}__{energy}__{suffix}.png");
            let mark =
                if gap.certified == Some(false) && kind != PlotKind::NegEigIter { " (E* not certified)" } else { "" };
            let title = format!("{dataset}, {energy}: {what}{mark}");
            let png = render_curves(&title, &kind, &curves, &gap)?;
            write_atomic(&run_dir.join(&file), &png)?;
            Ok(Plot { file, title, dataset: dataset.into(), energy: energy.into(), kind })
        })
        .collect::<Result<Vec<_>>>()
}

/// What the gap axis of a group's plots measures.
struct Gap<'a> {
    /// The verdict's gap `(E - E*) / span` (else `E - best`).
    judged: bool,
    /// The targets, drawn as lines (judged only).
    targets: &'a [f64],
    /// Whether `E*` is certified (`None`: not judged).
    certified: Option<bool>,
}

/// Log-axis floor for the gap: values at or below 0 (at or below `E*`) are drawn there. Two
/// decades below the smallest positive gap and the tightest target, so they read as "reached
/// it", but never below round-off.
fn gap_floor(curves: &[Series], targets: &[f64]) -> f64 {
    let gaps = curves.iter().flat_map(|c| c.curve.gap.iter().copied()).chain(targets.iter().copied());
    super::chart::gap_floor(gaps, curves.iter().map(|c| c.curve.roundoff))
}

/// The x axis of a plot of `curves` and each curve's points on it (gaps at or below `floor`
/// drawn at the floor; points off a log axis left out).
fn placed_points(kind: &PlotKind, curves: &[Series], floor: f64) -> (XAxis, Vec<Vec<(f64, f64)>>) {
    let x_axis = match kind {
        PlotKind::EnergyTime => {
            let t_max = curves.iter().flat_map(|c| c.curve.time.iter().copied()).filter(|t| t.is_finite());
            let t_max = t_max.fold(0.0, f64::max);
            XAxis::Linear { max: if t_max > 0.0 { t_max * 1.02 } else { 1.0 } }
        }
        _ => XAxis::for_iterations(curves.iter().map(|c| c.curve.iter.last().copied().unwrap_or(0.0))),
    };
    let points: Vec<Vec<(f64, f64)>> = curves
        .iter()
        .map(|Series { curve: c, .. }| {
            let xs = if *kind == PlotKind::EnergyTime { &c.time } else { &c.iter };
            let ys: Vec<f64> = match kind {
                PlotKind::NegEigIter => c.neg_eig.clone(),
                _ => c.gap.iter().map(|g| if g.is_finite() && *g <= floor { floor } else { *g }).collect(),
            };
            let pts = xs.iter().zip(ys).map(|(x, y)| (x_axis.place(*x), y));
            pts.filter(|(x, y)| x.is_finite() && y.is_finite()).collect()
        })
        .collect();
    (x_axis, points)
}

fn render_curves(title: &str, kind: &PlotKind, curves: &[Series], gap: &Gap) -> Result<Vec<u8>> {
    let floor = gap_floor(curves, gap.targets);
    let (x_axis, points) = placed_points(kind, curves, floor);
    render_framed(curves, &points, |chart_area| {
        let y_max = points.iter().flatten().map(|p| p.1).fold(0.0, f64::max);
        let x_desc = x_axis.describe(if *kind == PlotKind::EnergyTime { "time (s)" } else { "iteration" });
        let mut builder = ChartBuilder::on(chart_area);
        builder.caption(title, ("sans-serif", 20)).margin(12).x_label_area_size(42).y_label_area_size(70);
        // The four charts differ only in their axes' types (linear or log x, counts or log y).
        macro_rules! chart {
            ($x:expr, $y:expr, $y_desc:expr, $y_fmt:expr) => {{
                let mut chart = builder.build_cartesian_2d($x, $y)?;
                let mut mesh = chart.configure_mesh();
                mesh.x_desc(x_desc.as_str())
                    .y_desc($y_desc)
                    .y_label_formatter(&$y_fmt)
                    .x_label_formatter(&|v| format_linear(*v));
                house_style(&mut mesh).draw()?;
                if *kind != PlotKind::NegEigIter {
                    // The targets: a run is solved at tau where its final gap is at or below it.
                    let (x0, x1) = match x_axis {
                        XAxis::Linear { max } => (0.0, max),
                        XAxis::Log { lo, max } => (lo, max),
                    };
                    let grey = RGBColor(90, 90, 90);
                    for &tau in gap.targets {
                        chart.draw_series(DashedLineSeries::new([(x0, tau), (x1, tau)], 6, 4, grey.stroke_width(1)))?;
                        let label = Text::new(
                            format!("target {tau:.0e}"),
                            (x0, tau),
                            ("sans-serif", 13).into_font().color(&grey),
                        );
                        chart.draw_series(std::iter::once(label))?;
                    }
                }
                draw_series(&mut chart, curves, &points, x_axis)?;
            }};
        }
        let counts = |v: &f64| format_count(*v);
        let exponent = |v: &f64| format!("{v:.0e}");
        let gap_desc = if gap.judged {
            "(E − E*) / span, the verdict's gap (≤ 0 at the bottom)"
        } else {
            "E − best  (≤ 0 drawn at the bottom)"
        };
        match (kind, x_axis) {
            (PlotKind::NegEigIter, XAxis::Linear { max }) => {
                chart!(0.0..max, 0.0..neg_eig_max(y_max), "#negative eigenvalues", counts)
            }
            (PlotKind::NegEigIter, XAxis::Log { lo, max }) => {
                chart!((lo..max).log_scale(), 0.0..neg_eig_max(y_max), "#negative eigenvalues", counts)
            }
            // A little room below the floor so the markers drawn there are not clipped.
            (_, XAxis::Linear { max }) => {
                chart!(0.0..max, (floor / 2.0..gap_max(y_max, floor)).log_scale(), gap_desc, exponent)
            }
            (_, XAxis::Log { lo, max }) => {
                chart!((lo..max).log_scale(), (floor / 2.0..gap_max(y_max, floor)).log_scale(), gap_desc, exponent)
            }
        }
        Ok(())
    })
}

fn neg_eig_max(y_max: f64) -> f64 {
    if y_max > 0.0 {
        y_max * 1.05
    } else {
        1.0
    }
}

fn gap_max(y_max: f64, floor: f64) -> f64 {
    if y_max > floor {
        y_max * 2.0
    } else {
        floor * 10.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_and_negative_gaps_sit_on_the_floor_of_the_log_axis() {
        let curve = |gap: Vec<f64>| Curve {
            iter: vec![0.0; gap.len()],
            time: vec![0.0; gap.len()],
            neg_eig: vec![0.0; gap.len()],
            gap,
            roundoff: 4e-16,
        };
        let series = |solver, _: usize, converged, gap| Series {
            solver,
            style: chart::style(&["a", "b"], solver),
            converged,
            curve: curve(gap),
        };
        let curves = vec![series("a", 0, true, vec![6.0, 1e-3, 0.0]), series("b", 1, false, vec![6.0, -1e-9])];
        let floor = gap_floor(&curves, &[]);
        assert_eq!(floor, 1e-5);
        let plain = Gap { judged: false, targets: &[], certified: None };
        for kind in [PlotKind::EnergyIter, PlotKind::EnergyTime, PlotKind::NegEigIter] {
            render_curves("t", &kind, &curves, &plain).unwrap();
        }
        // The targets are drawn above the floor.
        let judged = Gap { judged: true, targets: &[1e-3, 1e-6], certified: Some(false) };
        assert_eq!(gap_floor(&curves, judged.targets), 1e-8);
        render_curves("t", &PlotKind::EnergyIter, &curves, &judged).unwrap();
        // Only zeros: the floor is round-off.
        let zeros = vec![series("a", 0, true, vec![0.0, 0.0])];
        assert_eq!(gap_floor(&zeros, &[]), 4e-16);
        render_curves("t", &PlotKind::EnergyIter, &zeros, &plain).unwrap();
    }

    #[test]
    fn the_iteration_axis_is_logarithmic_when_curve_lengths_span_a_decade() {
        let axis = |lengths: &[f64]| XAxis::for_iterations(lengths.iter().copied());
        assert_eq!(axis(&[3.0, 1000.0]), XAxis::Log { lo: 0.8, max: 1100.0 });
        assert_eq!(axis(&[0.0, 12.0]), XAxis::Log { lo: 0.8, max: 12.0 * 1.1 }, "a run of 0 iterations counts as 1");
        assert_eq!(axis(&[5.0, 20.0]), XAxis::Linear { max: 20.0 * 1.02 });
        assert_eq!(axis(&[0.0, 8.0]), XAxis::Linear { max: 8.0 * 1.02 }, "under 10 iterations: linear");
        assert_eq!(axis(&[]), XAxis::Linear { max: 1.0 });
        // Iteration 0 sits at the left end of a log axis.
        assert_eq!(axis(&[3.0, 1000.0]).place(0.0), 0.8);
        assert_eq!(axis(&[5.0, 20.0]).place(0.0), 0.0);
    }

    #[test]
    fn a_curve_with_the_same_iterates_as_an_earlier_one_is_its_twin() {
        let curve =
            |gap: Vec<f64>| Curve { iter: (0..gap.len()).map(|i| i as f64).collect(), gap, ..Default::default() };
        let names = ["kp-newton", "cm", "slim", "kp-newton-eig8"];
        let series = |i: usize, gap: Vec<f64>| Series {
            solver: names[i],
            style: chart::style(&names, names[i]),
            converged: true,
            curve: curve(gap),
        };
        let curves = vec![
            series(0, vec![4.0, 1.0, 0.0]),
            series(1, vec![4.0, 1.0, 0.0]),
            series(2, vec![4.0, 2.0, 0.5]),
            series(3, vec![4.0, 1.0, 0.0]),
        ];
        let points = crate::report::plots::chart::iter_gap_points(&curves);
        assert_eq!(chart::twins(&points), [None, Some(0), None, Some(0)]);
        // The same iterates at other times are no twins in the time plot.
        let mut timed = points.clone();
        timed[1][2].0 += 1.0;
        assert_eq!(chart::twins(&timed), [None, None, None, Some(0)]);
        render_curves("t", &PlotKind::EnergyIter, &curves, &Gap { judged: false, targets: &[], certified: None })
            .unwrap();
    }
}
