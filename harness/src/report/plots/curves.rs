//! Convergence curves of one (dataset, energy) group: energy gap vs iteration and vs time,
//! #negative eigenvalues vs iteration (the complex-view paper's Figures 2-3).

use super::chart::{self, draw_series, format_count, format_linear, house_style, render_framed, Curve, Series};
use super::{Plot, PlotKind};
use crate::report::converged;
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
    let curves = runs
        .par_iter()
        .map(|r| {
            let curve = Curve::new(crate::run_folder::read_run(run_dir, r)?);
            Ok(Series { solver: &r.solver, style: chart::style(solvers, &r.solver), converged: converged(r), curve })
        })
        .collect::<Result<Vec<_>>>()?;
    let kinds = [PlotKind::EnergyIter, PlotKind::EnergyTime, PlotKind::NegEigIter];
    kinds
        .into_par_iter()
        .map(|kind| {
            let (suffix, what) = match kind {
                PlotKind::EnergyIter => ("energy_iter", "energy gap vs iteration"),
                PlotKind::EnergyTime => ("energy_time", "energy gap vs time"),
                _ => ("neg_eig_iter", "#negative eigenvalues vs iteration"),
            };
            let file = format!("plots/{dataset}__{energy}__{suffix}.png");
            let title = format!("{dataset}, {energy}: {what}");
            let png = render_curves(&title, &kind, &curves)?;
            write_atomic(&run_dir.join(&file), &png)?;
            Ok(Plot { file, title, dataset: dataset.into(), energy: energy.into(), kind })
        })
        .collect::<Result<Vec<_>>>()
}

/// Log-axis floor for the energy gap: values at or below 0 (the best run's last point) are
/// drawn there. Two decades below the smallest positive gap, so they read as "reached the
/// best", but never below round-off of the best energy.
fn gap_floor(curves: &[Series]) -> f64 {
    let best = curves.iter().map(|c| c.curve.best.abs()).find(|b| b.is_finite()).unwrap_or(0.0);
    let min_pos = curves
        .iter()
        .flat_map(|c| c.curve.gap.iter().copied())
        .filter(|g| g.is_finite() && *g > 0.0)
        .fold(f64::INFINITY, f64::min);
    let roundoff = (1e-16 * best).max(1e-300);
    if min_pos.is_finite() {
        (min_pos / 100.0).max(roundoff)
    } else {
        roundoff
    }
}

fn render_curves(title: &str, kind: &PlotKind, curves: &[Series]) -> Result<Vec<u8>> {
    render_framed(curves, |chart_area| {
        let floor = gap_floor(curves);
        let points: Vec<Vec<(f64, f64)>> = curves
            .iter()
            .map(|Series { curve: c, .. }| {
                let xs = if *kind == PlotKind::EnergyTime { &c.time } else { &c.iter };
                let ys: Vec<f64> = match kind {
                    PlotKind::NegEigIter => c.neg_eig.clone(),
                    _ => c.gap.iter().map(|g| if g.is_finite() && *g <= floor { floor } else { *g }).collect(),
                };
                let pts = xs.iter().zip(ys).map(|(x, y)| (*x, y)).filter(|(x, y)| x.is_finite() && y.is_finite());
                pts.collect()
            })
            .collect();
        let all = points.iter().flatten();
        let x_max = all.clone().map(|p| p.0).fold(0.0, f64::max);
        let x_max = if x_max > 0.0 { x_max * 1.02 } else { 1.0 };
        let y_max = all.map(|p| p.1).fold(0.0, f64::max);
        let x_desc = if *kind == PlotKind::EnergyTime { "time (s)" } else { "iteration" };
        let mut builder = ChartBuilder::on(chart_area);
        builder.caption(title, ("sans-serif", 20)).margin(12).x_label_area_size(42).y_label_area_size(70);
        match kind {
            PlotKind::NegEigIter => {
                let y_max = if y_max > 0.0 { y_max * 1.05 } else { 1.0 };
                let mut chart = builder.build_cartesian_2d(0.0..x_max, 0.0..y_max)?;
                let mut mesh = chart.configure_mesh();
                mesh.x_desc(x_desc)
                    .y_desc("#negative eigenvalues")
                    .y_label_formatter(&|v| format_count(*v))
                    .x_label_formatter(&|v| format_linear(*v));
                house_style(&mut mesh).draw()?;
                draw_series(&mut chart, curves, &points, x_max)?;
            }
            _ => {
                let y_max = if y_max > floor { y_max * 2.0 } else { floor * 10.0 };
                // A little room below the floor so the markers drawn there are not clipped.
                let mut chart = builder.build_cartesian_2d(0.0..x_max, (floor / 2.0..y_max).log_scale())?;
                let mut mesh = chart.configure_mesh();
                mesh.x_desc(x_desc)
                    .y_desc("E − E*  (≤ 0 drawn at the bottom)")
                    .y_label_formatter(&|v| format!("{v:.0e}"))
                    .x_label_formatter(&|v| format_linear(*v));
                house_style(&mut mesh).draw()?;
                draw_series(&mut chart, curves, &points, x_max)?;
            }
        }
        Ok(())
    })
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
            best: 4.0,
        };
        let series = |solver, style, converged, gap| Series { solver, style, converged, curve: curve(gap) };
        let curves = vec![series("a", 0, true, vec![6.0, 1e-3, 0.0]), series("b", 1, false, vec![6.0, -1e-9])];
        let floor = gap_floor(&curves);
        assert_eq!(floor, 1e-5);
        for kind in [PlotKind::EnergyIter, PlotKind::EnergyTime, PlotKind::NegEigIter] {
            render_curves("t", &kind, &curves).unwrap();
        }
        // Only zeros: the floor is round-off of the best energy.
        let zeros = vec![series("a", 0, true, vec![0.0, 0.0])];
        assert_eq!(gap_floor(&zeros), 4e-16);
        render_curves("t", &PlotKind::EnergyIter, &zeros).unwrap();
    }
}
