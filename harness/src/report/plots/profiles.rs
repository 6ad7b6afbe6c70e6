//! Dolan–Moré performance profiles per energy (`profile__<energy>__iterations.png` and
//! `__time.png`): the step functions of [`crate::report::corpus::performance_profiles`]
//! drawn on a log2 τ axis, one line per solver in its usual color and marker; and Moré–Wild
//! data profiles (`profile__<energy>__data.png`): [`crate::report::corpus::data_profiles`] of
//! the time to the target on a log10 budget axis.

use super::chart::{self, draw_series, format_linear, house_style, iter_gap_points, render_framed, Series};
use super::chart::{Curve, XAxis};
use super::plot::{Plot, PlotKind, ALL_DATASETS};
use crate::report::corpus::{
    data_profiles, performance_profiles, DataProfiles, Profiles, TimeUnit, PROFILE_MIN_ITERATIONS, PROFILE_MIN_TIME,
};
use crate::report::select::unique;
use crate::report::target::{tau_text, tightest_target};
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use plotters::prelude::*;
use std::path::Path;

/// The two performance profiles of every energy (the authalic one too: its runs are judged
/// against a reference minimum like the others) with at least one problem in its common
/// problem set, and its data profile when some solver solved a problem, written under
/// `run_dir/plots/`.
pub(super) fn render_profiles(run_dir: &Path, summaries: &[SummaryRow], solvers: &[&str]) -> Result<Vec<Plot>> {
    let rows: Vec<&SummaryRow> = summaries.iter().collect();
    let unit = TimeUnit::choose(rows.iter().copied());
    let energies = unique(rows.iter().map(|r| r.energy.as_str()));
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
        let data = data_profiles(&runs, |r| unit.timed(r).map(|t| t.value), PROFILE_MIN_TIME);
        let Some(budget) = data.budget_range().filter(|_| !data.problems.is_empty()) else { continue };
        let to = tightest_target(runs.iter().copied())
            .map_or("time to solve".to_string(), |t| format!("time to {}", tau_text(t)));
        let file = format!("plots/profile__{energy}__data.png");
        let title = format!("{energy}: data profile, {to} ({} datasets)", data.problems.len());
        let x_desc = match unit {
            TimeUnit::Calibrated => format!("budget α: {to} in calibration units (log10 axis)"),
            TimeUnit::Seconds => format!("budget α: {to} in seconds (log10 axis)"),
        };
        let png = render_data_profile(&title, &x_desc, &data, budget, solvers)?;
        write_atomic(&run_dir.join(&file), &png)?;
        plots.push(Plot {
            file,
            title,
            dataset: ALL_DATASETS.into(),
            energy: energy.into(),
            kind: PlotKind::ProfileData,
        });
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
    let steps = profiles.profiles.iter().map(|p| (p.solver.as_str(), p.steps(tau_max))).collect();
    let x_label = |v: &f64| tick(*v, x_max);
    let x_desc = "τ: within this factor of the best solver (log2 axis)";
    render_fractions(title, x_desc, (0.0, x_max), &x_label, steps, solvers)
}

/// The label of a budget tick at `x` decades above 10^`d0`: only whole decades (0.01, 1, 1e5).
fn decade_tick(x: f64, d0: f64) -> String {
    let k = x + d0;
    if (k - k.round()).abs() > 1e-9 {
        return String::new();
    }
    let k = k.round() as i32;
    if (-2..=4).contains(&k) {
        format_linear(10f64.powi(k))
    } else {
        format!("1e{k}")
    }
}

/// The data profile's steps on a log10 budget axis from `lo` to `hi`, shifted by whole
/// decades so that the axis starts in [0, 1) (the markers' spacing needs x ≥ 0).
fn render_data_profile(
    title: &str,
    x_desc: &str,
    data: &DataProfiles,
    (lo, hi): (f64, f64),
    solvers: &[&str],
) -> Result<Vec<u8>> {
    let d0 = lo.log10().floor();
    let shifted = |steps: Vec<(f64, f64)>| steps.into_iter().map(|(x, y)| (x - d0, y)).collect();
    let steps = data.profiles.iter().map(|p| (p.solver.as_str(), shifted(p.steps(lo, hi)))).collect();
    let x_label = |v: &f64| decade_tick(*v, d0);
    render_fractions(title, x_desc, (lo.log10() - d0, hi.log10() - d0), &x_label, steps, solvers)
}

/// A profile chart: per solver, the fraction of datasets solved (y in [0, 1]) as steps over
/// `x_min..x_max`, the x ticks labelled by `x_label`.
fn render_fractions(
    title: &str,
    x_desc: &str,
    (x_min, x_max): (f64, f64),
    x_label: &dyn Fn(&f64) -> String,
    steps: Vec<(&str, Vec<(f64, f64)>)>,
    solvers: &[&str],
) -> Result<Vec<u8>> {
    let curves: Vec<Series> = steps
        .into_iter()
        .map(|(solver, steps)| {
            let curve = Curve {
                iter: steps.iter().map(|s| s.0).collect(),
                gap: steps.iter().map(|s| s.1).collect(),
                ..Default::default()
            };
            Series { solver, style: chart::style(solvers, solver), converged: true, curve }
        })
        .collect();
    let points = iter_gap_points(&curves);
    render_framed(&curves, &points, |chart_area| {
        let mut builder = ChartBuilder::on(chart_area);
        builder.caption(title, ("sans-serif", 18)).margin(12).x_label_area_size(42).y_label_area_size(60);
        // Room above 1 and below 0 and at both ends so the markers on the edges are not clipped.
        let pad = 0.02 * (x_max - x_min);
        let mut chart = builder.build_cartesian_2d(x_min - pad..x_max + pad, -0.03..1.05)?;
        let fraction = |v: &f64| if (0.0..=1.0).contains(v) { format_linear(*v) } else { String::new() };
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(x_desc)
            .y_desc("fraction of datasets solved")
            .x_label_formatter(x_label)
            .y_label_formatter(&fraction);
        house_style(&mut mesh).draw()?;
        draw_series(&mut chart, &curves, &points, XAxis::Linear { max: x_max })?;
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
    fn three_profiles_per_energy_named_by_the_issues_and_none_without_problems() {
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
            // authalic at a fixed budget: a run that reached the target is solved, one that
            // spent the budget above it is not
            SummaryRow { task: Task::Authalic, ..row("c", "authalic", "aem-cg", Status::Ok, 100) },
            SummaryRow { task: Task::Authalic, ..row("c", "authalic", "sem", Status::Budget, 100) },
        ];
        let plots = render_profiles(dir.path(), &rows, &["kp-newton", "cm", "aem-cg", "sem"]).unwrap();
        let files: Vec<&str> = plots.iter().map(|p| p.file.as_str()).collect();
        assert_eq!(
            files,
            [
                "plots/profile__sd__iterations.png",
                "plots/profile__sd__time.png",
                "plots/profile__sd__data.png",
                "plots/profile__authalic__iterations.png",
                "plots/profile__authalic__time.png",
                "plots/profile__authalic__data.png"
            ]
        );
        assert_eq!(plots[0].kind, PlotKind::ProfileIterations);
        assert_eq!(plots[2].kind, PlotKind::ProfileData);
        // Unjudged rows (no targets): the solvers' own stops, in seconds (no time_norm).
        assert_eq!(plots[2].title, "sd: data profile, time to solve (2 datasets)");
        assert_eq!(plots[0].dataset, ALL_DATASETS);
        assert!(plots[0].title.contains("2 datasets"), "{}", plots[0].title);
        for p in &plots {
            assert_eq!(png_size(&dir.path().join(&p.file)), CURVE_SIZE);
        }
        assert_eq!(
            (decade_tick(1.0, -2.0), decade_tick(0.5, -2.0), decade_tick(0.0, 0.0)),
            ("0.1".into(), "".into(), "1".into())
        );
        assert_eq!((decade_tick(2.0, 3.0), decade_tick(0.0, -3.0)), ("1e5".into(), "1e-3".into()));
        assert_eq!(tau_label(0.0), "1");
    }

    #[test]
    fn the_data_profile_of_a_judged_calibrated_batch_is_in_calibration_units_to_the_target() {
        use crate::run_folder::summary::ToTarget;
        let dir = tempfile::tempdir().unwrap();
        let row = |d: &str, s: &str, solved: bool| SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            iterations: Some(10),
            time_s: Some(2.0),
            time_norm: Some(4.0),
            status: if solved { Status::Ok } else { Status::NotConverged },
            to_targets: vec![ToTarget { tau: 1e-6, iters: solved.then_some(5), time_s: solved.then_some(0.5) }],
            ..Default::default()
        };
        let rows = crate::report::target::at_target(&[
            row("a", "cm", true),
            row("a", "slim", false),
            row("b", "cm", true),
            row("b", "slim", true),
        ]);
        // To the target: 0.5 s of 2 s, so a quarter of time_norm.
        assert_eq!(rows[0].time_norm, Some(1.0));
        let runs: Vec<&SummaryRow> = rows.iter().collect();
        let data = data_profiles(&runs, |r| TimeUnit::Calibrated.timed(r).map(|t| t.value), PROFILE_MIN_TIME);
        assert_eq!(data.profiles[0].costs, [1.0, 1.0]);
        assert_eq!(data.profiles[1].costs, [1.0, f64::INFINITY]);
        assert_eq!((data.profiles[1].fraction_within(0.9), data.profiles[1].fraction_within(1.0)), (0.0, 0.5));
        let plots = render_profiles(dir.path(), &rows, &["cm", "slim"]).unwrap();
        let data_plot = plots.iter().find(|p| p.kind == PlotKind::ProfileData).expect("a data profile");
        assert_eq!(data_plot.file, "plots/profile__sd__data.png");
        assert_eq!(data_plot.title, "sd: data profile, time to 1e-6 (2 datasets)");
        assert_eq!(png_size(&dir.path().join(&data_plot.file)), CURVE_SIZE);
        assert_eq!(tau_label(3.0), "8");
        assert_eq!(tau_label(0.5), "1.41");
        assert_eq!(
            (tick(0.5, 1.3), tick(0.5, 4.5), tick(4.0, 4.5), tick(-0.1, 4.5)),
            ("1.41".into(), "".into(), "16".into(), "".into())
        );
    }
}
