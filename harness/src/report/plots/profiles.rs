//! Dolan–Moré performance profiles per energy (`profile__<energy>__iterations.png` and
//! `__time.png`): the step functions of [`crate::report::corpus::performance_profiles`]
//! drawn on a log2 τ axis, one line per solver in its usual color and marker.

use super::chart::{self, draw_series, format_linear, house_style, iter_gap_points, render_framed, Series};
use super::curves::Curve;
use super::{Plot, PlotKind, ALL_DATASETS};
use crate::report::corpus::{performance_profiles, Profiles, TimeUnit, PROFILE_MIN_ITERATIONS, PROFILE_MIN_TIME};
use crate::report::is_param_or_deform;
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use plotters::prelude::*;
use std::path::Path;

/// The two profiles of every `param`/`deform` energy with at least one problem in its common
/// problem set, written under `run_dir/plots/`.
pub(super) fn render_profiles(run_dir: &Path, summaries: &[SummaryRow], solvers: &[&str]) -> Result<Vec<Plot>> {
    let rows: Vec<&SummaryRow> = summaries.iter().filter(|r| is_param_or_deform(r)).collect();
    let unit = TimeUnit::choose(rows.iter().copied());
    let mut energies: Vec<&str> = Vec::new();
    for r in &rows {
        if !energies.contains(&r.energy.as_str()) {
            energies.push(&r.energy);
        }
    }
    let mut plots = Vec::new();
    for energy in energies {
        let runs: Vec<&SummaryRow> = rows.iter().copied().filter(|r| r.energy == energy).collect();
        for kind in [PlotKind::ProfileIterations, PlotKind::ProfileTime] {
            let profiles = match kind {
                PlotKind::ProfileIterations => {
                    performance_profiles(&runs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS)
                }
                _ => performance_profiles(&runs, |r| unit.timed(r).map(|t| t.value), PROFILE_MIN_TIME),
            };
            if profiles.problems.is_empty() || profiles.profiles.is_empty() {
                continue;
            }
            let (suffix, what) = match kind {
                PlotKind::ProfileIterations => ("iterations", "iterations"),
                _ => ("time", "time"),
            };
            let file = format!("plots/profile__{energy}__{suffix}.png");
            let title = format!("{energy}: performance profile, {what} ({} datasets)", profiles.problems.len());
            let png = render_profile(&title, &profiles, solvers)?;
            write_atomic(&run_dir.join(&file), &png)?;
            plots.push(Plot { file, title, dataset: ALL_DATASETS.into(), energy: energy.into(), kind });
        }
    }
    Ok(plots)
}

/// Tick labels of the log2 axis: τ itself (1, 2, 4, 1.41).
fn tau_label(log2_tau: f64) -> String {
    format_linear((2f64.powf(log2_tau) * 100.0).round() / 100.0)
}

/// The label of the tick at `log2_tau` on an axis up to `x_max`: only powers of two once the
/// axis spans two of them (plotters also ticks half steps: 1.41, 2.83, 22.63), none left of 1.
fn tick(log2_tau: f64, x_max: f64) -> String {
    let power_of_two = (log2_tau - log2_tau.round()).abs() < 1e-9;
    if log2_tau < -1e-9 || (x_max >= 2.0 && !power_of_two) {
        String::new()
    } else {
        tau_label(log2_tau)
    }
}

fn render_profile(title: &str, profiles: &Profiles, solvers: &[&str]) -> Result<Vec<u8>> {
    let tau_max = profiles.tau_max();
    let x_max = tau_max.log2();
    let curves: Vec<Series> = profiles
        .profiles
        .iter()
        .map(|p| {
            let steps = p.steps(tau_max);
            let curve = Curve {
                iter: steps.iter().map(|s| s.0).collect(),
                gap: steps.iter().map(|s| s.1).collect(),
                ..Default::default()
            };
            Series { solver: &p.solver, style: chart::style(solvers, &p.solver), converged: true, curve }
        })
        .collect();
    render_framed(&curves, |chart_area| {
        let points = iter_gap_points(&curves);
        let mut builder = ChartBuilder::on(chart_area);
        builder.caption(title, ("sans-serif", 18)).margin(12).x_label_area_size(42).y_label_area_size(60);
        // Room above 1 and below 0 so the markers on the edges are not clipped.
        let mut chart = builder.build_cartesian_2d(-0.02 * x_max..x_max * 1.01, -0.03..1.05)?;
        let x_label = |v: &f64| tick(*v, x_max);
        let mut mesh = chart.configure_mesh();
        mesh.x_desc("τ: within this factor of the best solver (log2 axis)")
            .y_desc("fraction of datasets solved")
            .x_label_formatter(&x_label)
            .y_label_formatter(&|v| if (0.0..=1.0).contains(v) { format_linear(*v) } else { String::new() });
        house_style(&mut mesh).draw()?;
        draw_series(&mut chart, &curves, &points, x_max)?;
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
    fn two_profiles_per_energy_named_by_the_issue_and_none_without_problems() {
        let dir = tempfile::tempdir().unwrap();
        let row = |d: &str, e: &str, s: &str, status: Status, it: usize| SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: e.into(),
            solver: s.into(),
            iterations: Some(it),
            time_s: Some(0.01 * it as f64),
            status,
            ..Default::default()
        };
        let rows = vec![
            row("a", "sd", "kp-newton", Status::Ok, 10),
            row("a", "sd", "cm", Status::Ok, 20),
            row("b", "sd", "kp-newton", Status::NotConverged, 1000),
            row("b", "sd", "cm", Status::Ok, 40),
            // bconf: every pair skipped, no profile.
            row("a", "bconf", "kp-newton", Status::Skipped, 0),
        ];
        let plots = render_profiles(dir.path(), &rows, &["kp-newton", "cm"]).unwrap();
        let files: Vec<&str> = plots.iter().map(|p| p.file.as_str()).collect();
        assert_eq!(files, ["plots/profile__sd__iterations.png", "plots/profile__sd__time.png"]);
        assert_eq!(plots[0].kind, PlotKind::ProfileIterations);
        assert_eq!(plots[0].dataset, ALL_DATASETS);
        assert!(plots[0].title.contains("2 datasets"), "{}", plots[0].title);
        for p in &plots {
            assert_eq!(png_size(&dir.path().join(&p.file)), CURVE_SIZE);
        }
        assert_eq!(tau_label(0.0), "1");
        assert_eq!(tau_label(3.0), "8");
        assert_eq!(tau_label(0.5), "1.41");
        assert_eq!(
            (tick(0.5, 1.3), tick(0.5, 4.5), tick(4.0, 4.5), tick(-0.1, 4.5)),
            ("1.41".into(), "".into(), "16".into(), "".into())
        );
    }
}
