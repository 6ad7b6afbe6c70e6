//! The PNG plots of a run folder, read back from its files alone (`runs/*.csv`, `uv/*.obj`):
//! per (dataset, energy) the convergence curves of every solver (energy gap vs iteration and
//! vs time, #negative eigenvalues vs iteration, as in the complex-view paper's Figures 2-3),
//! and per run the final map with each triangle colored by its distortion.

use crate::mapfile::{self, MapFile};
use crate::output::{run_stem, write_atomic, SummaryRow};
use anyhow::{bail, Context, Result};
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Once;

/// Curve plots: wide enough for a legend column right of the chart.
const CURVE_SIZE: (u32, u32) = (800, 500);
/// Map renderings: the map square plus a title and a color bar below it.
const MAP_SIZE: (u32, u32) = (500, 540);
/// Width of the legend column of curve plots.
const LEGEND_WIDTH: u32 = 190;
/// Edges are drawn only below this many triangles and when triangles cover this many pixels
/// on average; otherwise they would turn the map grey.
const MAX_FACES_WITH_EDGES: usize = 3000;
const MIN_PIXELS_PER_FACE_WITH_EDGES: f64 = 40.0;

/// What a plot shows.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlotKind {
    /// `energy_minus_best` vs iteration, log y.
    EnergyIter,
    /// `energy_minus_best` vs cumulative time, log y.
    EnergyTime,
    /// `neg_eig` vs iteration.
    NegEigIter,
    /// The final map of one solver's run, colored by per-triangle distortion.
    Map { solver: String },
    /// Median time per iteration vs vertices over all datasets of an energy, log-log (the
    /// composite-majorization paper's Figure 6 shape).
    ScalingTime,
    /// Iterations vs vertices over all datasets of an energy, log x.
    ScalingIterations,
}

/// The `dataset` of the plots that span every dataset.
pub const ALL_DATASETS: &str = "all datasets";

/// Scaling plots need at least this many distinct mesh sizes.
pub const SCALING_MIN_SIZES: usize = 3;

/// One PNG written under the run folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Path relative to the run folder, e.g. `plots/bumpy_1k__sd__energy_iter.png`.
    pub file: String,
    pub title: String,
    pub dataset: String,
    pub energy: String,
    pub kind: PlotKind,
}

/// The tab10 palette; a solver's color is its index in order of first appearance in the summary.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// plotters has no system fonts here (no `ttf` feature): register the embedded DejaVu once.
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Only fails on a malformed font, and the embedded one is fixed at build time.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Render every plot of a run folder into `run_dir/plots/` and return them in report order:
/// per (dataset, energy) group the three curve plots, then the maps of its runs.
pub fn render_all(run_dir: &Path, summaries: &[SummaryRow]) -> Result<Vec<Plot>> {
    let mut solvers: Vec<&str> = Vec::new();
    let mut groups: Vec<(&str, &str)> = Vec::new();
    for s in summaries {
        if !solvers.contains(&s.solver.as_str()) {
            solvers.push(&s.solver);
        }
        if !groups.contains(&(s.dataset.as_str(), s.energy.as_str())) {
            groups.push((&s.dataset, &s.energy));
        }
    }
    let style = |solver: &str| solvers.iter().position(|s| *s == solver).unwrap_or(0);
    // Groups, and the plots inside a group, render in parallel (the caller's rayon pool);
    // indexed collects keep the plots in the groups' order.
    let per_group = |&(dataset, energy): &(&str, &str)| -> Result<Vec<Plot>> {
        let runs: Vec<&SummaryRow> =
            summaries.iter().filter(|s| s.dataset == dataset && s.energy == energy && s.status != "failed").collect();
        if runs.is_empty() {
            return Ok(Vec::new());
        }
        let curves = runs
            .par_iter()
            .map(|r| {
                let curve = Curve::new(crate::resume::read_run(run_dir, r)?);
                Ok(Series { solver: &r.solver, style: style(&r.solver), converged: r.status == "ok", curve })
            })
            .collect::<Result<Vec<_>>>()?;
        let kinds = [PlotKind::EnergyIter, PlotKind::EnergyTime, PlotKind::NegEigIter];
        let mut plots = kinds
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
            .collect::<Result<Vec<_>>>()?;
        // Read every map of the group first: they share one color scale.
        let maps = runs
            .par_iter()
            .map(|r| {
                let stem = run_stem(dataset, energy, &r.solver);
                let obj = run_dir.join("uv").join(format!("{stem}.obj"));
                if !obj.exists() {
                    return Ok(None);
                }
                let map = mapfile::read(&obj)?;
                let measure = if r.task == "authalic" { Measure::AreaRatio } else { Measure::Distortion };
                let values = measure.values(&map);
                Ok(Some((r.solver.as_str(), obj, map, values, measure)))
            })
            .collect::<Result<Vec<_>>>()?
            .into_iter()
            .flatten()
            .collect::<Vec<_>>();
        let Some(measure) = maps.first().map(|m| m.4) else { return Ok(plots) };
        let scale = ColorScale::fit(measure, &maps.iter().map(|m| m.3.as_slice()).collect::<Vec<_>>());
        let map_plots = maps
            .par_iter()
            .map(|(solver, obj, map, values, _)| {
                let stem = run_stem(dataset, energy, solver);
                let title = format!("{dataset}, {energy}, {solver}: final map");
                let png = render_map(&title, map, values, &scale)
                    .with_context(|| format!("{}: cannot render", obj.display()))?;
                let file = format!("plots/{stem}__map.png");
                write_atomic(&run_dir.join(&file), &png)?;
                Ok(Plot {
                    file,
                    title,
                    dataset: dataset.into(),
                    energy: energy.into(),
                    kind: PlotKind::Map { solver: solver.to_string() },
                })
            })
            .collect::<Result<Vec<_>>>()?;
        plots.extend(map_plots);
        Ok(plots)
    };
    let (groups, scaling) = rayon::join(
        || groups.par_iter().map(per_group).collect::<Result<Vec<_>>>(),
        || render_scaling(run_dir, summaries, &solvers),
    );
    let mut plots: Vec<Plot> = groups?.into_iter().flatten().collect();
    plots.extend(scaling?);
    Ok(plots)
}

/// Per energy with runs on at least [`SCALING_MIN_SIZES`] mesh sizes: the median time per
/// iteration and the iterations against the vertex count, one line per solver.
fn render_scaling(run_dir: &Path, summaries: &[SummaryRow], solvers: &[&str]) -> Result<Vec<Plot>> {
    let mut plots = Vec::new();
    let mut energies: Vec<&str> = Vec::new();
    for s in summaries.iter().filter(|s| s.task != "authalic") {
        if !energies.contains(&s.energy.as_str()) {
            energies.push(&s.energy);
        }
    }
    for energy in energies {
        let runs: Vec<&SummaryRow> = summaries
            .iter()
            .filter(|s| s.energy == energy && s.status != "failed" && s.task != "authalic" && s.vertices.is_some())
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
            for (style, solver) in solvers.iter().enumerate() {
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
                let converged = runs.iter().filter(|r| r.solver == *solver).all(|r| r.status == "ok");
                curves.push(Series { solver, style, converged, curve });
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
/// `log_y`) with a marker at every point.
fn render_xy_log(title: &str, y_desc: &str, log_y: bool, curves: &[Series]) -> Result<Vec<u8>> {
    register_font();
    let mut buf = vec![255u8; (CURVE_SIZE.0 * CURVE_SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, CURVE_SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let (chart_area, legend_area) = root.split_horizontally(CURVE_SIZE.0 - LEGEND_WIDTH);
        let points: Vec<Vec<(f64, f64)>> =
            curves.iter().map(|s| s.curve.iter.iter().copied().zip(s.curve.gap.iter().copied()).collect()).collect();
        let all = || points.iter().flatten();
        let (x_min, x_max) = (all().map(|p| p.0).fold(f64::INFINITY, f64::min), all().map(|p| p.0).fold(0.0, f64::max));
        let (y_min, y_max) = (all().map(|p| p.1).fold(f64::INFINITY, f64::min), all().map(|p| p.1).fold(0.0, f64::max));
        let xr = (x_min / 1.3)..(x_max * 1.3);
        let mut builder = ChartBuilder::on(&chart_area);
        builder.caption(title, ("sans-serif", 20)).margin(12).x_label_area_size(42).y_label_area_size(70);
        // Markers at every point: a marker slot far smaller than any gap between sizes.
        let every_point = x_min * 1e-9;
        if log_y {
            let mut chart = builder.build_cartesian_2d(xr.log_scale(), ((y_min / 1.5)..(y_max * 1.5)).log_scale())?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc("vertices (log)")
                .y_desc(format!("{y_desc} (log)"))
                .x_label_formatter(&|v| format_linear(*v))
                .y_label_formatter(&|v| format_linear(*v));
            house_style(&mut mesh).draw()?;
            draw_series(&mut chart, curves, &points, every_point)?;
        } else {
            let mut chart = builder.build_cartesian_2d(xr.log_scale(), 0.0..(y_max * 1.1))?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc("vertices (log)")
                .y_desc(y_desc)
                .x_label_formatter(&|v| format_linear(*v))
                .y_label_formatter(&|v| format_count(*v));
            house_style(&mut mesh).draw()?;
            draw_series(&mut chart, curves, &points, every_point)?;
        }
        draw_legend(&legend_area, curves)?;
        root.present()?;
    }
    encode_png(&buf, CURVE_SIZE)
}

/// One solver's curve in a plot.
struct Series<'a> {
    solver: &'a str,
    /// The solver's index in summary order: picks its color and marker in every plot.
    style: usize,
    /// Not converged runs are drawn dashed.
    converged: bool,
    curve: Curve,
}

impl Series<'_> {
    fn color(&self) -> RGBColor {
        PALETTE[self.style % PALETTE.len()]
    }
}

/// The columns of a per-iteration CSV the plots use. Non-finite values are kept (and skipped
/// when drawn) so a diverging run still shows its finite part.
#[derive(Clone, Debug, Default)]
struct Curve {
    iter: Vec<f64>,
    gap: Vec<f64>,
    time: Vec<f64>,
    neg_eig: Vec<f64>,
    /// The group's best energy, `energy - energy_minus_best` of the first row.
    best: f64,
}

impl Curve {
    fn new(file: crate::resume::IterationFile) -> Curve {
        let rows = &file.rows;
        Curve {
            iter: rows.iter().map(|r| r.iter as f64).collect(),
            time: rows.iter().map(|r| r.t_cum_s).collect(),
            neg_eig: rows.iter().map(|r| r.neg_eig as f64).collect(),
            best: rows.first().zip(file.energy_minus_best.first()).map_or(f64::NAN, |(r, g)| r.energy - g),
            gap: file.energy_minus_best,
        }
    }
}

/// Encode an RGB buffer as PNG.
fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    // zlib level 1: a third of the default level's encoding time (the bulk of `report` on a
    // batch of small runs) for about a third more bytes.
    enc.set_deflate_compression(png::DeflateCompression::Level(1));
    let mut writer = enc.write_header().context("PNG header")?;
    writer.write_image_data(rgb).context("PNG data")?;
    writer.finish().context("PNG end")?;
    Ok(out)
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
    register_font();
    let mut buf = vec![255u8; (CURVE_SIZE.0 * CURVE_SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, CURVE_SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let (chart_area, legend_area) = root.split_horizontally(CURVE_SIZE.0 - LEGEND_WIDTH);
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
        let mut builder = ChartBuilder::on(&chart_area);
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
        draw_legend(&legend_area, curves)?;
        root.present()?;
    }
    encode_png(&buf, CURVE_SIZE)
}

/// The look every curve plot's axes share: label sizes and light grid lines.
fn house_style<'m, 'a, 'b, X, Y, DB>(mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>) -> &'m mut MeshStyle<'a, 'b, X, Y, DB>
where
    X: Ranged,
    Y: Ranged,
    DB: DrawingBackend,
{
    mesh.label_style(("sans-serif", 14))
        .light_line_style(BLACK.mix(0.04))
        .bold_line_style(BLACK.mix(0.15))
        .axis_desc_style(("sans-serif", 15))
}

/// Markers along the x axis: at most this many per curve, evenly spaced in x.
const MARKERS_PER_AXIS: f64 = 16.0;

/// Lines (dashed when the run did not converge) plus markers whose shape changes with the
/// solver, so curves that coincide (FP4/FP6, CM/KP on SD) stay distinguishable. Markers go
/// at the first and last point and where a curve enters a new x slot; each solver's slots
/// are shifted so coinciding curves show their markers side by side.
fn draw_series<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    curves: &[Series],
    points: &[Vec<(f64, f64)>],
    x_max: f64,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate<From = (f64, f64)>,
{
    let slot = x_max / MARKERS_PER_AXIS;
    for (s, pts) in curves.iter().zip(points) {
        let line = s.color().stroke_width(2);
        if s.converged {
            chart.draw_series(LineSeries::new(pts.iter().copied(), line))?;
        } else {
            chart.draw_series(DashedLineSeries::new(pts.iter().copied(), 8, 5, line))?;
        }
        let shift = slot * (s.style % 4) as f64 / 4.0;
        let mut last_slot = None;
        for (i, p) in pts.iter().enumerate() {
            let k = ((p.0 + shift) / slot).floor() as i64;
            if last_slot != Some(k) || i + 1 == pts.len() {
                draw_marker(chart.plotting_area(), s.style, *p, s.color())?;
                last_slot = Some(k);
            }
        }
    }
    Ok(())
}

/// Draw the marker of the solver with index `style` at `p`: circle, triangle, square, cross.
fn draw_marker<DB, CT>(area: &DrawingArea<DB, CT>, style: usize, p: CT::From, color: RGBColor) -> Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    CT: CoordTranslate,
    CT::From: Clone,
{
    let filled = color.filled();
    let at = || EmptyElement::at(p.clone());
    match style % 4 {
        0 => area.draw(&(at() + Circle::new((0, 0), 4, filled)))?,
        1 => area.draw(&(at() + TriangleMarker::new((0, 0), 5, filled)))?,
        2 => area.draw(&(at() + Rectangle::new([(-4, -4), (4, 4)], filled)))?,
        _ => area.draw(&(at() + Cross::new((0, 0), 4, color.stroke_width(2))))?,
    }
    Ok(())
}

/// Tick labels of linear axes: integers without a fraction, otherwise a short float.
fn format_linear(v: f64) -> String {
    if v == v.round() && v.abs() < 1e6 {
        format!("{v:.0}")
    } else if v.abs() >= 0.01 && v.abs() < 1e4 {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

/// #NE ticks: counts, but plotters may place ticks at fractions for small ranges.
fn format_count(v: f64) -> String {
    if v == v.round() {
        format!("{v:.0}")
    } else {
        String::new()
    }
}

/// A boxed legend in its own column, so it never covers data.
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[Series]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let row = 22;
    let (top, left) = (50, 4);
    let height = row * entries.len() as i32 + 10;
    let width = LEGEND_WIDTH as i32 - 2 * left - 4;
    area.draw(&Rectangle::new([(left, top), (left + width, top + height)], BLACK.mix(0.6).stroke_width(1)))?;
    let font = TextStyle::from(("sans-serif", 14).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (k, s) in entries.iter().enumerate() {
        let y = top + 5 + row * k as i32 + row / 2;
        let line = s.color().stroke_width(2);
        if s.converged {
            area.draw(&PathElement::new(vec![(left + 6, y), (left + 34, y)], line))?;
        } else {
            area.draw(&PathElement::new(vec![(left + 4, y), (left + 12, y)], line))?;
            area.draw(&PathElement::new(vec![(left + 28, y), (left + 36, y)], line))?;
        }
        draw_marker(area, s.style, (left + 20, y), s.color())?;
        area.draw(&Text::new(s.solver.to_string(), (left + 42, y), font.clone()))?;
    }
    if entries.iter().any(|s| !s.converged) {
        let note = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Top));
        area.draw(&Text::new("dashed: not converged", (left + 2, top + height + 6), note))?;
    }
    Ok(())
}

/// What the map coloring shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Measure {
    /// `max(σ1, 1/σ2)` of the triangle's Jacobian, normalized to a similarity (`param`, `deform`).
    Distortion,
    /// Triangle area share in the map over its share in the source (`authalic`).
    AreaRatio,
}

/// A triangle's value for the coloring; `None` when the map flips (or folds) it.
type Shade = Option<f64>;

/// Area of a source triangle and its edge matrix in its own 2D frame (first edge along x):
/// `[[a, bx], [0, by]]` as `(a, bx, by)`.
fn source_frame(p: [[f64; 3]; 3]) -> (f64, f64, f64) {
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let a = (e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]).sqrt();
    let cross = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let by = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt() / a;
    let bx = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / a;
    (a, bx, by)
}

/// Signed area of a map triangle.
fn map_area(q: [[f64; 2]; 3]) -> f64 {
    0.5 * ((q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]))
}

/// Singular values `(σ1 ≥ σ2 ≥ 0)` and determinant of the Jacobian from the source triangle
/// (in its own frame) to the map triangle.
fn jacobian_sv(p: [[f64; 3]; 3], q: [[f64; 2]; 3]) -> (f64, f64, f64) {
    let (a, bx, by) = source_frame(p);
    // J = M S^{-1} with M the map edge matrix and S = [[a, bx], [0, by]].
    let (m00, m01) = (q[1][0] - q[0][0], q[2][0] - q[0][0]);
    let (m10, m11) = (q[1][1] - q[0][1], q[2][1] - q[0][1]);
    let (j00, j01) = (m00 / a, (m01 - m00 * bx / a) / by);
    let (j10, j11) = (m10 / a, (m11 - m10 * bx / a) / by);
    // Closed-form 2x2 SVD: J = similarity part (e, h) + anti-similarity part (f, g).
    let (e, f) = ((j00 + j11) / 2.0, (j00 - j11) / 2.0);
    let (g, h) = ((j10 + j01) / 2.0, (j10 - j01) / 2.0);
    let (qs, rs) = (e.hypot(h), f.hypot(g));
    (qs + rs, (qs - rs).abs(), j00 * j11 - j01 * j10)
}

fn corners(map: &MapFile, f: &[usize; 3]) -> ([[f64; 3]; 3], [[f64; 2]; 3]) {
    (f.map(|v| map.source[v]), f.map(|v| map.uv[v]))
}

/// Per triangle `max(σ1, 1/σ2)` of the Jacobian divided by the global scale
/// `sqrt(map area / source area)`, so any similarity gives exactly 1 (the map lives in an
/// area-1 frame, the source in its own units). `None` for flipped triangles; NaN when the
/// source triangle is degenerate.
fn distortion(map: &MapFile) -> Vec<Shade> {
    let (src_total, map_total) = total_areas(map);
    let scale = (map_total / src_total).sqrt();
    map.faces
        .iter()
        .map(|f| {
            let (p, q) = corners(map, f);
            let (s1, s2, det) = jacobian_sv(p, q);
            if det <= 0.0 {
                return None;
            }
            Some((s1 / scale).max(scale / s2))
        })
        .collect()
}

/// Per triangle its share of the map's area over its share of the source's area (1 = area
/// preserved); `None` for folded triangles.
fn area_ratios(map: &MapFile) -> Vec<Shade> {
    let (src_total, map_total) = total_areas(map);
    map.faces
        .iter()
        .map(|f| {
            let (p, q) = corners(map, f);
            let (a, _, by) = source_frame(p);
            let m = map_area(q);
            if m <= 0.0 {
                return None;
            }
            Some((m / map_total) / (0.5 * a * by / src_total))
        })
        .collect()
}

/// Total source area and total absolute map area.
fn total_areas(map: &MapFile) -> (f64, f64) {
    map.faces.iter().fold((0.0, 0.0), |(s, m), f| {
        let (p, q) = corners(map, f);
        let (a, _, by) = source_frame(p);
        (s + 0.5 * a * by, m + map_area(q).abs())
    })
}

/// Linear interpolation through evenly spaced color anchors, `t` in [0, 1].
fn ramp(anchors: &[(u8, u8, u8)], t: f64) -> [u8; 3] {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (anchors.len() - 1) as f64;
    let i = (x.floor() as usize).min(anchors.len() - 2);
    let w = x - i as f64;
    let (a, b) = (anchors[i], anchors[i + 1]);
    let mix = |u: u8, v: u8| (u as f64 + w * (v as f64 - u as f64)).round() as u8;
    [mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2)]
}

/// Sequential yellow-orange-red (ColorBrewer YlOrRd) for distortion 1 ... DISTORTION_MAX.
const YLORRD: [(u8, u8, u8); 5] = [(255, 255, 204), (254, 217, 118), (253, 141, 60), (227, 26, 28), (128, 0, 38)];
/// Diverging blue-white-red (ColorBrewer RdBu reversed) for area ratios around 1.
const RDBU: [(u8, u8, u8); 5] = [(33, 102, 172), (146, 197, 222), (247, 247, 247), (244, 165, 130), (178, 24, 43)];
/// Flipped triangles: a color absent from the palette in use.
const FLIPPED_DISTORTION: [u8; 3] = [0, 110, 255];
const FLIPPED_AREA: [u8; 3] = [0, 0, 0];
/// Degenerate source triangles (no defined distortion).
const UNDEFINED: [u8; 3] = [160, 160, 160];

impl Measure {
    fn values(self, map: &MapFile) -> Vec<Shade> {
        match self {
            Measure::Distortion => distortion(map),
            Measure::AreaRatio => area_ratios(map),
        }
    }
}

/// Upper ends the color scale snaps to, so scales are round numbers.
const SCALE_STEPS: [f64; 12] = [1.01, 1.02, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0, 4.0, 8.0, 16.0, 100.0];

/// The color scale of the maps of one (dataset, energy) group: distortion from 1 to `max`,
/// or area ratio from `1/max` to `max`, log scale. One scale per group keeps the solvers'
/// maps comparable; adapting it to the group keeps near-perfect maps (authalic maps often
/// stay within 1%) from rendering as a flat color.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ColorScale {
    measure: Measure,
    max: f64,
}

impl ColorScale {
    /// The smallest step covering 99% of the triangles of all `values` (flips excluded).
    fn fit(measure: Measure, values: &[&[Shade]]) -> ColorScale {
        let mut spread: Vec<f64> = values
            .iter()
            .flat_map(|v| v.iter().flatten())
            .filter(|v| v.is_finite() && **v > 0.0)
            .map(|v| v.max(1.0 / v))
            .collect();
        let q = if spread.is_empty() {
            1.0
        } else {
            let k = ((spread.len() - 1) as f64 * 0.99).round() as usize;
            *spread.select_nth_unstable_by(k, f64::total_cmp).1
        };
        let max = SCALE_STEPS.iter().copied().find(|s| *s >= q).unwrap_or(SCALE_STEPS[SCALE_STEPS.len() - 1]);
        ColorScale { measure, max }
    }

    /// Position on the color bar in [0, 1] (clamped when drawn).
    fn t(&self, v: f64) -> f64 {
        match self.measure {
            Measure::Distortion => v.ln() / self.max.ln(),
            Measure::AreaRatio => 0.5 + 0.5 * v.ln() / self.max.ln(),
        }
    }

    fn ramp(&self, t: f64) -> [u8; 3] {
        match self.measure {
            Measure::Distortion => ramp(&YLORRD, t),
            Measure::AreaRatio => ramp(&RDBU, t),
        }
    }

    fn flipped(&self) -> [u8; 3] {
        match self.measure {
            Measure::Distortion => FLIPPED_DISTORTION,
            Measure::AreaRatio => FLIPPED_AREA,
        }
    }

    fn color(&self, shade: Shade) -> [u8; 3] {
        match shade {
            Some(v) if !v.is_finite() => UNDEFINED,
            Some(v) => self.ramp(self.t(v)),
            None => self.flipped(),
        }
    }

    /// Color bar ticks (value, label) at 5 evenly spaced positions, the ends open-ended.
    fn ticks(&self) -> Vec<(f64, String)> {
        let (lo, hi) = match self.measure {
            Measure::Distortion => (0.0, 1.0),
            Measure::AreaRatio => (-1.0, 1.0),
        };
        (0..5)
            .map(|i| {
                let e = lo + (hi - lo) * i as f64 / 4.0;
                let v = self.max.powf(e);
                let text = if (v - 1.0).abs() < 1e-12 { "1".to_string() } else { format_tick(v) };
                let text = match i {
                    0 if lo < 0.0 => format!("≤{text}"),
                    4 => format!("≥{text}"),
                    _ => text,
                };
                (v, text)
            })
            .collect()
    }

    /// The bar's description and the flipped swatch's label.
    fn labels(&self) -> (&'static str, &'static str) {
        match self.measure {
            Measure::Distortion => ("distortion max(σ₁, 1/σ₂), 1 = similarity, log scale", "flipped"),
            Measure::AreaRatio => ("area ratio map/source (area shares), log scale", "folded"),
        }
    }
}

/// Three significant digits without trailing zeros (1.05, 0.952, 16).
fn format_tick(v: f64) -> String {
    let digits = (2 - v.abs().log10().floor() as i64).clamp(0, 6) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Fill one triangle (pixel coordinates) into an RGB buffer: every pixel whose center lies
/// inside or on an edge, plus the centroid's pixel so sub-pixel triangles still show.
fn fill_triangle(buf: &mut [u8], (w, h): (u32, u32), t: [(f64, f64); 3], color: [u8; 3]) {
    let (w, h) = (w as i64, h as i64);
    let mut put = |x: i64, y: i64| {
        if x >= 0 && y >= 0 && x < w && y < h {
            let i = 3 * (y * w + x) as usize;
            buf[i..i + 3].copy_from_slice(&color);
        }
    };
    let cx = (t[0].0 + t[1].0 + t[2].0) / 3.0;
    let cy = (t[0].1 + t[1].1 + t[2].1) / 3.0;
    put(cx.floor() as i64, cy.floor() as i64);
    let x0 = t.iter().map(|p| p.0).fold(f64::INFINITY, f64::min).floor().max(0.0) as i64;
    let x1 = t.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max).ceil().min(w as f64) as i64;
    let y0 = t.iter().map(|p| p.1).fold(f64::INFINITY, f64::min).floor().max(0.0) as i64;
    let y1 = t.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max).ceil().min(h as f64) as i64;
    let edge = |a: (f64, f64), b: (f64, f64), x: f64, y: f64| (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0);
    for y in y0..y1 {
        for x in x0..x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let e = [edge(t[0], t[1], px, py), edge(t[1], t[2], px, py), edge(t[2], t[0], px, py)];
            // Inclusive on both orientations, so shared edges leave no gap and flips still fill.
            if e.iter().all(|v| *v >= 0.0) || e.iter().all(|v| *v <= 0.0) {
                put(x, y);
            }
        }
    }
}

/// Edges used by one face only: the map's outline, drawn so a pale interior stays visible.
fn boundary_edges(faces: &[[usize; 3]]) -> Vec<(usize, usize)> {
    let mut count: std::collections::HashMap<(usize, usize), u32> = std::collections::HashMap::new();
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut edges: Vec<(usize, usize)> = count.into_iter().filter(|(_, c)| *c == 1).map(|(e, _)| e).collect();
    edges.sort_unstable();
    edges
}

/// The map region of a map rendering: below the title, above the color bar.
const MAP_BOX: (i32, i32, i32, i32) = (10, 34, 490, 470);

/// `values` are the map's per-triangle [`Measure`] values, colored by `scale`.
fn render_map(title: &str, map: &MapFile, values: &[Shade], scale: &ColorScale) -> Result<Vec<u8>> {
    register_font();
    let flipped = values.iter().filter(|v| v.is_none()).count();
    let finite = map.uv.iter().filter(|p| p[0].is_finite() && p[1].is_finite());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in finite {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0] < hi[0] && lo[1] < hi[1]) {
        bail!("the map has no extent (all points equal or non-finite)");
    }
    // Equal aspect: one scale for u and v, the map centered in its box; v points up.
    let (bx0, by0, bx1, by1) = MAP_BOX;
    let (bw, bh) = ((bx1 - bx0) as f64, (by1 - by0) as f64);
    let zoom = (bw / (hi[0] - lo[0])).min(bh / (hi[1] - lo[1]));
    let ox = bx0 as f64 + 0.5 * (bw - zoom * (hi[0] - lo[0]));
    let oy = by0 as f64 + 0.5 * (bh - zoom * (hi[1] - lo[1]));
    let px = |p: [f64; 2]| (ox + zoom * (p[0] - lo[0]), oy + zoom * (hi[1] - p[1]));

    let mut buf = vec![255u8; (MAP_SIZE.0 * MAP_SIZE.1 * 3) as usize];
    for (f, v) in map.faces.iter().zip(values) {
        let t = f.map(|i| px(map.uv[i]));
        if t.iter().all(|p| p.0.is_finite() && p.1.is_finite()) {
            fill_triangle(&mut buf, MAP_SIZE, t, scale.color(*v));
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, MAP_SIZE).into_drawing_area();
        let ipx = |p: [f64; 2]| {
            let (x, y) = px(p);
            (x.round() as i32, y.round() as i32)
        };
        let finite = |p: [f64; 2]| p[0].is_finite() && p[1].is_finite();
        let pixels_per_face = zoom * zoom * total_areas(map).1 / map.faces.len() as f64;
        if map.faces.len() < MAX_FACES_WITH_EDGES && pixels_per_face >= MIN_PIXELS_PER_FACE_WITH_EDGES {
            let style = RGBAColor(0, 0, 0, 0.2).stroke_width(1);
            for f in &map.faces {
                if f.iter().all(|&i| finite(map.uv[i])) {
                    let mut pts: Vec<(i32, i32)> = f.iter().map(|&i| ipx(map.uv[i])).collect();
                    pts.push(pts[0]);
                    root.draw(&PathElement::new(pts, style))?;
                }
            }
        }
        let outline = RGBColor(60, 60, 60).stroke_width(1);
        for (a, b) in boundary_edges(&map.faces) {
            if finite(map.uv[a]) && finite(map.uv[b]) {
                root.draw(&PathElement::new(vec![ipx(map.uv[a]), ipx(map.uv[b])], outline))?;
            }
        }
        let center =
            |size: i32| TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
        root.draw(&Text::new(title.to_string(), (MAP_SIZE.0 as i32 / 2, 8), center(16)))?;
        draw_color_bar(&root, scale, flipped)?;
        root.present()?;
    }
    encode_png(&buf, MAP_SIZE)
}

/// A horizontal color bar under the map with its ticks, description and the flipped swatch.
fn draw_color_bar<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, scale: &ColorScale, flipped: usize) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (x0, x1, y0, y1) = (40, 330, 480, 494);
    for x in x0..x1 {
        let c = scale.ramp((x - x0) as f64 / (x1 - x0 - 1) as f64);
        root.draw(&PathElement::new(vec![(x, y0), (x, y1)], RGBColor(c[0], c[1], c[2])))?;
    }
    root.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))?;
    let tick_font = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
    for (v, label) in scale.ticks() {
        let x = x0 + (scale.t(v) * (x1 - x0 - 1) as f64).round() as i32;
        root.draw(&PathElement::new(vec![(x, y1), (x, y1 + 3)], BLACK))?;
        root.draw(&Text::new(label, (x, y1 + 4), tick_font.clone()))?;
    }
    let (description, flipped_label) = scale.labels();
    let left = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Top));
    root.draw(&Text::new(description.to_string(), (x0, y1 + 22), left.clone()))?;
    let c = scale.flipped();
    let sx = x1 + 30;
    root.draw(&Rectangle::new([(sx, y0), (sx + 14, y1)], RGBColor(c[0], c[1], c[2]).filled()))?;
    root.draw(&Text::new(format!("{flipped_label}: {flipped}"), (sx + 20, y0), left))?;
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::output::iteration_csv;
    use solvers::solver::IterationRecord;

    #[test]
    fn scaling_plots_need_three_sizes_and_are_log_log_pngs() {
        let dir = tempfile::tempdir().unwrap();
        let row = |d: &str, v: usize, solver: &str, ms: f64| SummaryRow {
            dataset: d.into(),
            task: "param".into(),
            energy: "sd".into(),
            solver: solver.into(),
            vertices: Some(v),
            iterations: Some(10),
            iter_ms_median: Some(ms),
            status: "ok".into(),
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

    /// Width and height from a PNG's signature and IHDR chunk; panics if it is not a PNG.
    pub(crate) fn png_size(path: &Path) -> (u32, u32) {
        let b = std::fs::read(path).unwrap();
        assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}: not a PNG", path.display());
        assert_eq!(&b[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        (be(16), be(20))
    }

    fn summary(dataset: &str, task: &str, solver: &str, status: &str, error: &str) -> SummaryRow {
        SummaryRow {
            dataset: dataset.into(),
            task: task.into(),
            energy: if task == "authalic" { "authalic".into() } else { "sd".into() },
            solver: solver.into(),
            iterations: Some(3),
            time_s: Some(0.25),
            converged: status == "ok",
            stop_reason: if status == "ok" { "grad_tol".into() } else { "max_iters".into() },
            status: status.into(),
            error: error.into(),
            ..Default::default()
        }
    }

    fn records(energies: &[f64], neg_eig: usize) -> Vec<IterationRecord> {
        energies
            .iter()
            .enumerate()
            .map(|(i, &energy)| IterationRecord {
                iter: i,
                energy,
                neg_eig: neg_eig.saturating_sub(10 * i),
                t_cum_s: 0.01 * i as f64,
                ..Default::default()
            })
            .collect()
    }

    /// A run folder as the runner leaves it: dataset `tiny` (param, two solvers that finished,
    /// one failed with markup in its error), dataset `disk` (authalic, one solver), CSVs, maps
    /// (`flat_disk_1k` under the identity and a shear) and meta.json.
    pub(crate) fn tiny_run() -> (tempfile::TempDir, Vec<SummaryRow>) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path();
        let rows = vec![
            summary("tiny", "param", "kp-newton", "ok", ""),
            summary("tiny", "param", "slim", "not_converged", ""),
            summary("tiny", "param", "cm", "failed", "factorization failed: pivot < 0 & NaN in <K>"),
            // Two iterations: the three rows written below.
            SummaryRow { iterations: Some(2), ..summary("disk", "authalic", "aem-cg", "ok", "") },
        ];
        let write = |stem: &str, bytes: Vec<u8>| write_atomic(&p.join("runs").join(format!("{stem}.csv")), &bytes);
        write("tiny__sd__kp-newton", iteration_csv(&records(&[10.0, 5.0, 4.5, 4.0], 40), 4.0).unwrap()).unwrap();
        write("tiny__sd__slim", iteration_csv(&records(&[10.0, 7.0, 6.0, 5.5], 40), 4.0).unwrap()).unwrap();
        write("tiny__sd__cm", iteration_csv(&records(&[10.0], 40), 10.0).unwrap()).unwrap();
        // A negative gap (the failed run's energy below the group best) must plot too.
        write("disk__authalic__aem-cg", iteration_csv(&records(&[1.0, 0.5, 0.25], 5), 0.3).unwrap()).unwrap();
        let mesh = solvers::generate::generate("flat_disk_1k").unwrap();
        let identity: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0], q[1]]).collect();
        let shear: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0] + 0.5 * q[1], q[1]]).collect();
        let obj = |stem: &str, x: &[f64]| {
            write_atomic(&p.join("uv").join(format!("{stem}.obj")), &mapfile::to_obj(&mesh, x)).unwrap()
        };
        obj("tiny__sd__kp-newton", &identity);
        obj("tiny__sd__slim", &shear);
        obj("disk__authalic__aem-cg", &shear);
        let meta = serde_json::json!({
            "config": {"name": "tiny-config", "task": "param"},
            "git_revision": "0123456789abcdef0123456789abcdef01234567", "git_dirty": true,
            "host": "testhost", "cores": 2, "started_unix": 1_700_000_000u64, "ended_unix": 1_700_000_042u64,
        });
        write_atomic(&p.join("meta.json"), meta.to_string().as_bytes()).unwrap();
        (dir, rows)
    }

    #[test]
    fn renders_every_group_and_map_as_png_of_the_requested_size() {
        let (dir, rows) = tiny_run();
        let plots = render_all(dir.path(), &rows).unwrap();
        let files: Vec<&str> = plots.iter().map(|p| p.file.as_str()).collect();
        assert_eq!(
            files,
            [
                "plots/tiny__sd__energy_iter.png",
                "plots/tiny__sd__energy_time.png",
                "plots/tiny__sd__neg_eig_iter.png",
                "plots/tiny__sd__kp-newton__map.png",
                "plots/tiny__sd__slim__map.png",
                "plots/disk__authalic__energy_iter.png",
                "plots/disk__authalic__energy_time.png",
                "plots/disk__authalic__neg_eig_iter.png",
                "plots/disk__authalic__aem-cg__map.png",
            ]
        );
        for p in &plots {
            let want = if matches!(p.kind, PlotKind::Map { .. }) { MAP_SIZE } else { CURVE_SIZE };
            assert_eq!(png_size(&dir.path().join(&p.file)), want, "{}", p.file);
        }
        assert_eq!(plots[4].kind, PlotKind::Map { solver: "slim".into() });
    }

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

    fn one_triangle(source: [[f64; 3]; 3], uv: [[f64; 2]; 3]) -> MapFile {
        MapFile { source: source.to_vec(), uv: uv.to_vec(), faces: vec![[0, 1, 2]] }
    }

    #[test]
    fn similarities_have_distortion_one() {
        // A tilted source triangle, mapped by its own 2D frame turned by 0.7 rad and scaled by 3.
        let src = [[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.2, 1.5, 0.3]];
        let (a, bx, by) = source_frame(src);
        let (c, s, k) = (0.7f64.cos(), 0.7f64.sin(), 3.0);
        let rot = |x: f64, y: f64| [k * (c * x - s * y) + 5.0, k * (s * x + c * y) - 2.0];
        let map = one_triangle(src, [rot(0.0, 0.0), rot(a, 0.0), rot(bx, by)]);
        let (s1, s2, det) = jacobian_sv(src, [map.uv[0], map.uv[1], map.uv[2]]);
        assert!((s1 - 3.0).abs() < 1e-12 && (s2 - 3.0).abs() < 1e-12 && (det - 9.0).abs() < 1e-12);
        let d = distortion(&map)[0].unwrap();
        assert!((d - 1.0).abs() < 1e-12, "{d}");
        let r = area_ratios(&map)[0].unwrap();
        assert!((r - 1.0).abs() < 1e-12, "{r}");
    }

    #[test]
    fn a_stretch_matches_the_closed_form() {
        // Two planar triangles of different shapes under (x, y) -> (2x, y): J = diag(2, 1) on
        // both; the global scale is sqrt(2), so max(σ1, 1/σ2) / normalized = 2/sqrt(2) = sqrt(2).
        let source = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.3, 1.0, 0.0], [1.5, 2.0, 0.0]];
        let uv = source.iter().map(|p| [2.0 * p[0], p[1]]).collect();
        let map = MapFile { source, uv, faces: vec![[0, 1, 2], [1, 3, 2]] };
        for f in &map.faces {
            let (p, q) = corners(&map, f);
            let (s1, s2, det) = jacobian_sv(p, q);
            assert!((s1 - 2.0).abs() < 1e-12 && (s2 - 1.0).abs() < 1e-12 && (det - 2.0).abs() < 1e-12);
        }
        for d in distortion(&map) {
            assert!((d.unwrap() - 2f64.sqrt()).abs() < 1e-12, "{d:?}");
        }
        // Area doubles everywhere: every share is unchanged.
        for r in area_ratios(&map) {
            assert!((r.unwrap() - 1.0).abs() < 1e-12, "{r:?}");
        }
        // Stretch only the second triangle's free vertex: its area share grows, the other's shrinks.
        let mut m2 = map.clone();
        m2.uv = m2.source.iter().map(|p| [p[0], p[1]]).collect();
        m2.uv[3] = [1.5, 2.0 + 1.0];
        let (a0, a1) = (0.5, map_area([m2.uv[1], m2.uv[3], m2.uv[2]]));
        let (s0, s1) = (0.5, map_area([[1.0, 0.0], [1.5, 2.0], [0.3, 1.0]]));
        let r = area_ratios(&m2);
        assert!((r[0].unwrap() - (a0 / (a0 + a1)) / (s0 / (s0 + s1))).abs() < 1e-12);
        assert!((r[1].unwrap() - (a1 / (a0 + a1)) / (s1 / (s0 + s1))).abs() < 1e-12);
    }

    #[test]
    fn flipped_triangles_are_detected() {
        let src = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        // A mirror image is a flip even though its singular values are those of an isometry.
        let mirrored = one_triangle(src, [[0.0, 0.0], [-1.0, 0.0], [0.0, 1.0]]);
        assert_eq!(distortion(&mirrored), vec![None]);
        assert_eq!(area_ratios(&mirrored), vec![None]);
        let scale = ColorScale { measure: Measure::Distortion, max: 4.0 };
        assert_eq!(scale.color(None), FLIPPED_DISTORTION);
        assert_ne!(scale.color(Some(1.0)), FLIPPED_DISTORTION);
        let fine = one_triangle(src, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!(distortion(&fine)[0].is_some());
    }

    #[test]
    fn the_color_scale_snaps_to_the_99th_percentile() {
        let values: Vec<Shade> = (0..1000).map(|i| Some(1.0 + 0.03 * i as f64 / 1000.0)).collect();
        let mut with_outliers = values.clone();
        with_outliers[..5].iter_mut().for_each(|v| *v = Some(50.0));
        with_outliers[5] = None;
        for v in [&values, &with_outliers] {
            assert_eq!(ColorScale::fit(Measure::Distortion, &[v]).max, 1.05);
        }
        // Area ratios count shrinking as much as growing.
        let shrunk: Vec<Shade> = vec![Some(1.0 / 1.15); 10];
        let area = ColorScale::fit(Measure::AreaRatio, &[&shrunk]);
        assert_eq!(area.max, 1.2);
        let ticks: Vec<String> = area.ticks().into_iter().map(|t| t.1).collect();
        assert_eq!(ticks, ["≤0.833", "0.913", "1", "1.1", "≥1.2"]);
        assert_eq!(area.t(1.0), 0.5);
    }

    #[test]
    fn fills_every_pixel_of_a_mesh_without_gaps() {
        // Two triangles sharing a diagonal cover the whole square: no white pixel inside.
        let size = (20, 20);
        let mut buf = vec![255u8; 20 * 20 * 3];
        let sq = [(2.0, 2.0), (18.0, 2.0), (18.0, 18.0), (2.0, 18.0)];
        fill_triangle(&mut buf, size, [sq[0], sq[1], sq[2]], [1, 2, 3]);
        fill_triangle(&mut buf, size, [sq[0], sq[3], sq[2]], [1, 2, 3]);
        for y in 2..18 {
            for x in 2..18 {
                assert_eq!(buf[3 * (y * 20 + x)], 1, "pixel {x},{y}");
            }
        }
        assert_eq!(buf[0], 255);
    }
}
