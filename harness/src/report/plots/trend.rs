//! The history's trend charts (`mapbench history`): one value per batch and solver, batches
//! in time order along x, each tick labelled with the batch's revision. Same look as the
//! curve plots (legend column, markers per solver).

use super::canvas::{encode_png, register_font};
use super::chart::{
    draw_legend, draw_series, format_linear, house_style, style, twins, Series, CURVE_SIZE, LEGEND_WIDTH,
};
use super::chart::{Curve, XAxis};
use anyhow::{bail, Result};
use plotters::prelude::*;
use plotters::style::FontTransform;

/// One solver's values: `(batch index, value)` for the batches it has one in.
pub struct TrendLine<'a> {
    pub solver: &'a str,
    pub points: Vec<(usize, f64)>,
}

/// A PNG of `lines` over the batches labelled `labels` (x ticks, one per batch); `solvers`
/// fixes each solver's color and marker as in the run reports.
pub fn render_trend(
    title: &str,
    y_desc: &str,
    labels: &[String],
    lines: &[TrendLine],
    solvers: &[&str],
) -> Result<Vec<u8>> {
    if labels.is_empty() || lines.iter().all(|l| l.points.is_empty()) {
        bail!("{title}: nothing to plot");
    }
    register_font();
    let series: Vec<Series> = lines
        .iter()
        .filter(|l| !l.points.is_empty())
        .map(|l| Series {
            solver: l.solver,
            style: style(solvers, l.solver),
            converged: true,
            curve: Curve {
                iter: l.points.iter().map(|p| p.0 as f64).collect(),
                gap: l.points.iter().map(|p| p.1).collect(),
                ..Default::default()
            },
        })
        .collect();
    let points: Vec<Vec<(f64, f64)>> =
        series.iter().map(|s| s.curve.iter.iter().copied().zip(s.curve.gap.iter().copied()).collect()).collect();
    let y_max = points.iter().flatten().map(|p| p.1).filter(|y| y.is_finite()).fold(0.0, f64::max);
    let y_max = if y_max > 0.0 { y_max * 1.1 } else { 1.0 };
    let n = labels.len();
    let mut buf = vec![255u8; (CURVE_SIZE.0 * CURVE_SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, CURVE_SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let (chart_area, legend_area) = root.split_horizontally(CURVE_SIZE.0 - LEGEND_WIDTH);
        let mut chart = ChartBuilder::on(&chart_area)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(92)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), 0.0..y_max)?;
        // A tick per batch, labelled with its revision (rotated: 30 of them fit).
        let label = |v: &f64| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                // plotters centres the rotated label on the tick: leading spaces (about half a
                // digit wide each) move it below the axis.
                let l = &labels[i as usize];
                format!("{}{l}", " ".repeat(2 * l.chars().count() + 2))
            } else {
                String::new()
            }
        };
        let mut mesh = chart.configure_mesh();
        mesh.x_labels(n)
            .x_desc("batch (git revision; + = dirty tree)")
            .y_desc(y_desc)
            .x_label_formatter(&label)
            .y_label_formatter(&|v| format_linear(*v));
        house_style(&mut mesh)
            .x_label_style(("sans-serif", 12).into_font().transform(FontTransform::Rotate90))
            .draw()?;
        // A marker at every point: a marker slot far smaller than the spacing of batches.
        draw_series(&mut chart, &series, &points, XAxis::Linear { max: 1e-9 })?;
        draw_legend(&legend_area, &series, &twins(&points))?;
        root.present()?;
    }
    encode_png(&buf, CURVE_SIZE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trend_chart_is_a_png_of_the_curve_size_and_empty_input_is_refused() {
        let labels: Vec<String> = ["abc1234", "def5678+", "0123456"].iter().map(|s| s.to_string()).collect();
        let lines = [
            TrendLine { solver: "kp-newton", points: vec![(0, 10.0), (1, 12.0), (2, 11.0)] },
            TrendLine { solver: "cm", points: vec![(1, 20.0)] },
        ];
        let png =
            render_trend("sd: mean iterations", "mean iterations", &labels, &lines, &["kp-newton", "cm"]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        std::fs::write(&path, &png).unwrap();
        assert_eq!(super::super::tests::png_size(&path), CURVE_SIZE);
        let none = [TrendLine { solver: "cm", points: vec![] }];
        assert!(render_trend("t", "y", &labels, &none, &["cm"]).is_err());
    }
}
