//! What the curve charts share: the size and legend column, one [`Series`] per solver with
//! its color and marker, the axes' house style and the tick label formats.

use super::canvas::{encode_png, register_font};
use super::colors::{looks, Look, MARKERS};
use anyhow::Result;
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Curve plots: wide enough for a legend column right of the chart.
pub(super) const CURVE_SIZE: (u32, u32) = (800, 500);
/// Width of the legend column of curve plots.
pub(super) const LEGEND_WIDTH: u32 = 230;

/// The columns of a per-iteration CSV the plots use. Non-finite values are kept (and skipped
/// when drawn) so a diverging run still shows its finite part.
#[derive(Clone, Debug, Default)]
pub(super) struct Curve {
    pub(super) iter: Vec<f64>,
    /// Each row's gap: the verdict's `(E - E*) / span` for a judged run, else
    /// `energy_minus_best` (an authalic run, or a folder without a reference).
    pub(super) gap: Vec<f64>,
    pub(super) time: Vec<f64>,
    pub(super) neg_eig: Vec<f64>,
    /// What a gap of round-off is: `1e-16 |E*| / span` (judged) or `1e-16 |best|`.
    pub(super) roundoff: f64,
}

impl Curve {
    /// The curve of a run's rows, on the verdict's yardstick `(E*, span)` when it has one.
    pub(super) fn new(file: crate::run_folder::IterationFile, yardstick: Option<(f64, f64)>) -> Curve {
        let rows = &file.rows;
        let (gap, roundoff) = match yardstick.filter(|(_, span)| *span > 0.0) {
            Some((e_star, span)) => (
                rows.iter().map(|r| crate::convergence::gap_on(r.energy, e_star, span)).collect(),
                1e-16 * e_star.abs() / span,
            ),
            None => {
                let best = rows.first().zip(file.energy_minus_best.first()).map_or(f64::NAN, |(r, g)| r.energy - g);
                (file.energy_minus_best, 1e-16 * best.abs())
            }
        };
        Curve {
            iter: rows.iter().map(|r| r.iter as f64).collect(),
            time: rows.iter().map(|r| r.t_cum_s).collect(),
            neg_eig: rows.iter().map(|r| r.neg_eig as f64).collect(),
            gap,
            roundoff,
        }
    }
}

/// Where a gap at or below 0 (at or below `E*`) is drawn on a log axis: two decades under
/// the least positive gap or target of the plot, and not under round-off (`roundoff`: the
/// first curve's positive one). The PNG plots and the explorer share it.
pub(super) fn gap_floor(gaps: impl IntoIterator<Item = f64>, roundoff: impl IntoIterator<Item = f64>) -> f64 {
    let roundoff = roundoff.into_iter().find(|b| b.is_finite() && *b > 0.0).unwrap_or(0.0).max(1e-300);
    let least = gaps.into_iter().filter(|g| g.is_finite() && *g > 0.0).fold(f64::INFINITY, f64::min);
    if least.is_finite() {
        (least / 100.0).max(roundoff)
    } else {
        roundoff
    }
}

/// One solver's curve in a plot.
pub(super) struct Series<'a> {
    pub(super) solver: &'a str,
    /// The solver's color and marker, the same in every plot of the page.
    pub(super) style: Look,
    /// Not converged runs are drawn dashed.
    pub(super) converged: bool,
    pub(super) curve: Curve,
}

impl Series<'_> {
    fn color(&self) -> RGBColor {
        self.style.color
    }
}

/// A solver's look among `solvers` (the summary's order, every solver of the page), so it
/// keeps its color and marker in every plot.
pub(super) fn style(solvers: &[&str], solver: &str) -> Look {
    let at = solvers.iter().position(|s| *s == solver);
    match at {
        Some(i) => looks(solvers)[i],
        None => looks(&[solver])[0],
    }
}

/// For each curve of a chart (its plotted points), the first earlier curve with the very same
/// points, which it would hide: such a curve is drawn dashed over it and the legend names the
/// twin.
pub(super) fn twins(points: &[Vec<(f64, f64)>]) -> Vec<Option<usize>> {
    (0..points.len()).map(|i| (0..i).find(|&j| !points[i].is_empty() && points[i] == points[j])).collect()
}

/// The look every curve plot's axes share: label sizes and light grid lines.
pub(super) fn house_style<'m, 'a, 'b, X, Y, DB>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB>
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
pub(super) fn draw_series<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    curves: &[Series],
    points: &[Vec<(f64, f64)>],
    x_axis: XAxis,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate<From = (f64, f64)>,
{
    let to_axis = |x: f64| match x_axis {
        XAxis::Linear { .. } => x,
        XAxis::Log { lo, .. } => (x.max(lo) / lo).ln(),
    };
    let slot = to_axis(x_axis.max()) / MARKERS_PER_AXIS;
    let shift = |marker: usize| slot * (marker % 4) as f64 / 4.0;
    let twins = twins(points);
    for (n, (s, pts)) in curves.iter().zip(points).enumerate() {
        let line = s.color().stroke_width(2);
        if twins[n].is_some() {
            // Over its twin: short dashes, so both colors show along the one curve.
            chart.draw_series(DashedLineSeries::new(pts.iter().copied(), 4, 6, line))?;
        } else if s.converged {
            chart.draw_series(LineSeries::new(pts.iter().copied(), line))?;
        } else {
            chart.draw_series(DashedLineSeries::new(pts.iter().copied(), 8, 5, line))?;
        }
        let mut last_slot = None;
        for (i, p) in pts.iter().enumerate() {
            // Slots in the axis's own terms (log or linear), shifted per marker so that
            // coinciding curves show their markers side by side.
            let k = ((to_axis(p.0) + shift(s.style.marker)) / slot).floor() as i64;
            if last_slot != Some(k) || i + 1 == pts.len() {
                draw_marker(chart.plotting_area(), s.style.marker, *p, s.color())?;
                last_slot = Some(k);
            }
        }
    }
    Ok(())
}

/// Each curve's points as markers alone, no line between them: the points of different meshes
/// (the scaling plots) make no curve, and a line would draw a trend across unrelated shapes.
pub(super) fn draw_points<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    curves: &[Series],
    points: &[Vec<(f64, f64)>],
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate<From = (f64, f64)>,
{
    for (s, pts) in curves.iter().zip(points) {
        for p in pts {
            draw_marker(chart.plotting_area(), s.style.marker, *p, s.color())?;
        }
    }
    Ok(())
}

/// The x axis of a curve chart: linear from 0, or logarithmic from `lo` (where x = 0 is
/// drawn) when the curves' lengths span decades.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum XAxis {
    Linear { max: f64 },
    Log { lo: f64, max: f64 },
}

impl XAxis {
    /// Iterations: logarithmic when the longest curve has at least [`LOG_AXIS_RATIO`] times
    /// the iterations of the shortest (with at least 10), so that Newton's few iterations are
    /// not squeezed against the axis by a first-order method's thousand.
    pub(super) fn for_iterations(lengths: impl Iterator<Item = f64>) -> XAxis {
        let (lo, hi) = lengths.fold((f64::INFINITY, 0.0f64), |(lo, hi), n| (lo.min(n.max(1.0)), hi.max(n)));
        let max = if hi > 0.0 { hi * 1.02 } else { 1.0 };
        if hi >= 10.0 && hi >= LOG_AXIS_RATIO * lo {
            XAxis::Log { lo: 0.8, max: hi * 1.1 }
        } else {
            XAxis::Linear { max }
        }
    }

    pub(super) fn max(self) -> f64 {
        match self {
            XAxis::Linear { max } | XAxis::Log { max, .. } => max,
        }
    }

    /// A point's x on this axis: 0 sits at the left end of a log axis.
    pub(super) fn place(self, x: f64) -> f64 {
        match self {
            XAxis::Log { lo, .. } => x.max(lo),
            XAxis::Linear { .. } => x,
        }
    }

    /// The axis description: `what`, and how 0 is drawn on a log axis.
    pub(super) fn describe(self, what: &str) -> String {
        match self {
            XAxis::Linear { .. } => what.to_string(),
            XAxis::Log { .. } => format!("{what} (log scale; 0 at the left edge)"),
        }
    }
}

/// How many times the iterations of the shortest curve the longest must have for a log axis.
pub(super) const LOG_AXIS_RATIO: f64 = 10.0;

/// Draw marker shape `marker` (of [`MARKERS`]) at `p`: circle, triangle, square, cross,
/// diamond, downward triangle, ring, plus.
fn draw_marker<DB, CT>(area: &DrawingArea<DB, CT>, marker: usize, p: CT::From, color: RGBColor) -> Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    CT: CoordTranslate,
    CT::From: Clone,
{
    let filled = color.filled();
    let stroke = color.stroke_width(2);
    let at = || EmptyElement::at(p.clone());
    match marker % MARKERS {
        0 => area.draw(&(at() + Circle::new((0, 0), 4, filled)))?,
        1 => area.draw(&(at() + TriangleMarker::new((0, 0), 5, filled)))?,
        2 => area.draw(&(at() + Rectangle::new([(-4, -4), (4, 4)], filled)))?,
        3 => area.draw(&(at() + Cross::new((0, 0), 4, stroke)))?,
        4 => area.draw(&(at() + Polygon::new(vec![(0, -5), (5, 0), (0, 5), (-5, 0)], filled)))?,
        5 => area.draw(&(at() + Polygon::new(vec![(-5, -3), (5, -3), (0, 5)], filled)))?,
        6 => area.draw(&(at() + Circle::new((0, 0), 4, stroke)))?,
        _ => area.draw(
            &(at() + PathElement::new(vec![(-5, 0), (5, 0)], stroke) + PathElement::new(vec![(0, -5), (0, 5)], stroke)),
        )?,
    }
    Ok(())
}

/// Tick labels of linear axes: integers without a fraction, otherwise a short float.
pub(super) fn format_linear(v: f64) -> String {
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
pub(super) fn format_count(v: f64) -> String {
    if v == v.round() {
        format!("{v:.0}")
    } else {
        String::new()
    }
}

/// A boxed legend in its own column, so it never covers data; `twins` as [`twins`] of the
/// chart's points.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[Series],
    twins: &[Option<usize>],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (top, left) = (50, 4);
    // 22 pixels a row, closer for many solvers so that 24 still leave room for the notes.
    let row = 22.min((CURVE_SIZE.1 as i32 - top - 60) / entries.len().max(1) as i32).max(15);
    let height = row * entries.len() as i32 + 10;
    let width = LEGEND_WIDTH as i32 - 2 * left - 4;
    area.draw(&Rectangle::new([(left, top), (left + width, top + height)], BLACK.mix(0.6).stroke_width(1)))?;
    let twin = |k: usize| twins.get(k).copied().flatten();
    for (k, s) in entries.iter().enumerate() {
        let y = top + 5 + row * k as i32 + row / 2;
        let line = s.color().stroke_width(2);
        if twin(k).is_some() {
            for x in [4, 14, 24] {
                area.draw(&PathElement::new(vec![(left + x, y), (left + x + 4, y)], line))?;
            }
        } else if s.converged {
            area.draw(&PathElement::new(vec![(left + 6, y), (left + 34, y)], line))?;
        } else {
            area.draw(&PathElement::new(vec![(left + 4, y), (left + 12, y)], line))?;
            area.draw(&PathElement::new(vec![(left + 28, y), (left + 36, y)], line))?;
        }
        draw_marker(area, s.style.marker, (left + 20, y), s.color())?;
        let label = match twin(k) {
            Some(j) => format!("{} = {}", s.solver, entries[j].solver),
            None => s.solver.to_string(),
        };
        area.draw(&Text::new(label.clone(), (left + 42, y), legend_font(&label)))?;
    }
    if twins.iter().any(Option::is_some) {
        let note = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Top));
        let y = top + height + if entries.iter().any(|s| !s.converged) { 24 } else { 6 };
        area.draw(&Text::new("a = b: the same curve as b", (left + 2, y), note))?;
    }
    if entries.iter().any(|s| !s.converged) {
        let note = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Top));
        area.draw(&Text::new("dashed: not converged", (left + 2, top + height + 6), note))?;
    }
    Ok(())
}

/// The characters a legend label shows at 14 px in the column right of its marker.
const LEGEND_CHARS: usize = 22;

/// A legend label's font: 14 px, smaller for a longer label (down to 9 px, about 34
/// characters) so that `fp-trust-region-6x6 = fp-abs-6x6` is not cut at the column's edge.
fn legend_font(label: &str) -> TextStyle<'static> {
    let n = label.chars().count().max(1);
    let size = if n <= LEGEND_CHARS { 14.0 } else { (14.0 * LEGEND_CHARS as f64 / n as f64).round().max(9.0) };
    TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(HPos::Left, VPos::Center))
}

/// A curve chart's PNG: `draw` fills the chart area on the left, the legend of `curves` takes
/// the column on the right (`points`: what `draw` plots of each curve, for its twins).
pub(super) fn render_framed(
    curves: &[Series],
    points: &[Vec<(f64, f64)>],
    draw: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> Result<()>,
) -> Result<Vec<u8>> {
    register_font();
    let mut buf = vec![255u8; (CURVE_SIZE.0 * CURVE_SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, CURVE_SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let (chart_area, legend_area) = root.split_horizontally(CURVE_SIZE.0 - LEGEND_WIDTH);
        draw(&chart_area)?;
        draw_legend(&legend_area, curves, &twins(points))?;
        root.present()?;
    }
    encode_png(&buf, CURVE_SIZE)
}

/// Each series' `(iter, gap)` points: the x and y of the charts that are not per-run curves.
pub(super) fn iter_gap_points(curves: &[Series]) -> Vec<Vec<(f64, f64)>> {
    curves.iter().map(|s| s.curve.iter.iter().copied().zip(s.curve.gap.iter().copied()).collect()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_legend_label_takes_a_smaller_font_instead_of_being_cut() {
        let size = |label: &str| legend_font(label).font.get_size();
        assert_eq!(size("fp-trust-region-6x6"), 14.0);
        assert_eq!(size("fp-trust-region-6x6 = fp-abs-6x6"), 10.0);
        assert_eq!(size(&"x".repeat(80)), 9.0, "never below 9 px");
    }
}
