//! Scaling plots over every dataset of an energy: time per iteration and iterations against
//! the vertex count (the composite-majorization paper's Figure 6 shape), as points: the
//! datasets are different shapes, so no line suggests a trend between them.

use super::chart::Curve;
use super::chart::{
    self, draw_points, format_count, format_linear, house_style, iter_gap_points, render_framed, Series,
};
use super::plot::{Plot, PlotKind, ALL_DATASETS};
use crate::report::select::{converged, finished, is_authalic, unique};
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use plotters::prelude::*;
use std::path::Path;

/// Scaling plots need at least this many distinct mesh sizes.
pub const SCALING_MIN_SIZES: usize = 3;

/// Per energy with runs on at least [`SCALING_MIN_SIZES`] mesh sizes: the median time per
/// iteration and the iterations against the vertex count, one line per solver.
pub(super) fn render_scaling(run_dir: &Path, summaries: &[SummaryRow], solvers: &[&str]) -> Result<Vec<Plot>> {
    let mut plots = Vec::new();
    let energies = unique(summaries.iter().filter(|s| !is_authalic(s)).map(|s| s.energy.as_str()));
    for energy in energies {
        let runs: Vec<&SummaryRow> = summaries
            .iter()
            .filter(|s| s.energy == energy && finished(s) && !is_authalic(s) && s.vertices.is_some())
            .collect();
        let mut sizes: Vec<usize> = runs.iter().filter_map(|r| r.vertices).collect();
        sizes.sort_unstable();
        sizes.dedup();
        if sizes.len() < SCALING_MIN_SIZES {
            continue;
        }
        for kind in [PlotKind::ScalingTime, PlotKind::ScalingIterations] {
            let value = |r: &SummaryRow| match kind {
                PlotKind::ScalingTime => r.iter_ms_median,
                _ => r.iterations.map(|i| i as f64),
            };
            let mut curves = Vec::new();
            for solver in solvers {
                let mut pts: Vec<(f64, f64)> = runs
                    .iter()
                    .filter(|r| r.solver == *solver)
                    .filter_map(|r| Some((r.vertices? as f64, value(r)?)))
                    .filter(|p| p.1 > 0.0)
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let curve = Curve {
                    iter: pts.iter().map(|p| p.0).collect(),
                    gap: pts.iter().map(|p| p.1).collect(),
                    ..Default::default()
                };
                let converged = runs.iter().filter(|r| r.solver == *solver).all(|r| converged(r));
                curves.push(Series { solver, style: chart::style(solvers, solver), converged, curve });
            }
            if curves.is_empty() {
                continue;
            }
            let (suffix, what, y_desc) = match kind {
                PlotKind::ScalingTime => ("iter_ms", "time per iteration vs size", "median time per iteration (ms)"),
                _ => ("iterations", "iterations vs size", "iterations"),
            };
            let file = format!("plots/scaling__{energy}__{suffix}.png");
            let title = format!("{energy}: {what}");
            let png = render_xy_log(&title, y_desc, kind == PlotKind::ScalingTime, &curves)?;
            write_atomic(&run_dir.join(&file), &png)?;
            plots.push(Plot { file, title, dataset: ALL_DATASETS.into(), energy: energy.into(), kind });
        }
    }
    Ok(plots)
}

/// A plot of `curve.iter` (x, log axis: vertices) against `curve.gap` (y, log axis when
/// `log_y`): a marker at every point and no line, the meshes being unrelated shapes.
fn render_xy_log(title: &str, y_desc: &str, log_y: bool, curves: &[Series]) -> Result<Vec<u8>> {
    let points = iter_gap_points(curves);
    render_framed(curves, &points, |chart_area| {
        let all = || points.iter().flatten();
        let (x_min, x_max) = (all().map(|p| p.0).fold(f64::INFINITY, f64::min), all().map(|p| p.0).fold(0.0, f64::max));
        let (y_min, y_max) = (all().map(|p| p.1).fold(f64::INFINITY, f64::min), all().map(|p| p.1).fold(0.0, f64::max));
        let xr = (x_min / 1.3)..(x_max * 1.3);
        let mut builder = ChartBuilder::on(chart_area);
        builder.caption(title, ("sans-serif", 20)).margin(12).x_label_area_size(42).y_label_area_size(70);
        if log_y {
            let mut chart = builder.build_cartesian_2d(xr.log_scale(), ((y_min / 1.5)..(y_max * 1.5)).log_scale())?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc("vertices (log)")
                .y_desc(format!("{y_desc} (log)"))
                .x_label_formatter(&|v| format_linear(*v))
                .y_label_formatter(&|v| format_linear(*v));
            house_style(&mut mesh).draw()?;
            draw_points(&mut chart, curves, &points)?;
        } else {
            let mut chart = builder.build_cartesian_2d(xr.log_scale(), 0.0..(y_max * 1.1))?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc("vertices (log)")
                .y_desc(y_desc)
                .x_label_formatter(&|v| format_linear(*v))
                .y_label_formatter(&|v| format_count(*v));
            house_style(&mut mesh).draw()?;
            draw_points(&mut chart, curves, &points)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::report::plots::chart::CURVE_SIZE;
    use crate::report::plots::tests::png_size;
    use crate::run_folder::Status;

    #[test]
    fn scaling_plots_need_three_sizes_and_are_log_log_pngs() {
        let dir = tempfile::tempdir().unwrap();
        let row = |d: &str, v: usize, solver: &str, ms: f64| SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            vertices: Some(v),
            iterations: Some(10),
            iter_ms_median: Some(ms),
            status: Status::Ok,
            ..Default::default()
        };
        let mut rows = vec![row("a", 1_000, "kp-newton", 2.0), row("b", 10_000, "kp-newton", 25.0)];
        assert!(render_scaling(dir.path(), &rows, &["kp-newton"]).unwrap().is_empty());
        rows.extend([row("c", 200_000, "kp-newton", 900.0), row("c", 200_000, "cm", 700.0)]);
        let plots = render_scaling(dir.path(), &rows, &["kp-newton", "cm"]).unwrap();
        let kinds: Vec<&PlotKind> = plots.iter().map(|p| &p.kind).collect();
        assert_eq!(kinds, [&PlotKind::ScalingTime, &PlotKind::ScalingIterations]);
        assert_eq!(plots[0].file, "plots/scaling__sd__iter_ms.png");
        assert_eq!(plots[0].dataset, ALL_DATASETS);
        for p in &plots {
            assert_eq!(png_size(&dir.path().join(&p.file)), CURVE_SIZE);
        }
    }
}
