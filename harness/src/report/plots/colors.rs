//! Colors: the solvers' palette of the curve plots and the color scales of the maps.

use plotters::style::RGBColor;

/// The tab10 palette; a solver's color is its index in order of first appearance in the summary.
pub(super) const PALETTE: [RGBColor; 10] = [
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

/// What the map coloring shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Measure {
    /// `max(σ1, 1/σ2)` of the triangle's Jacobian, normalized to a similarity (`param`, `deform`).
    Distortion,
    /// Triangle area share in the map over its share in the source (`authalic`).
    AreaRatio,
}

/// A triangle's value for the coloring; `None` when the map flips (or folds) it.
pub(super) type Shade = Option<f64>;

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
pub(super) const FLIPPED_DISTORTION: [u8; 3] = [0, 110, 255];
const FLIPPED_AREA: [u8; 3] = [0, 0, 0];
/// Degenerate source triangles (no defined distortion).
pub(super) const UNDEFINED: [u8; 3] = [160, 160, 160];

/// Upper ends the color scale snaps to, so scales are round numbers.
const SCALE_STEPS: [f64; 12] = [1.01, 1.02, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0, 4.0, 8.0, 16.0, 100.0];

/// The color scale of the maps of one (dataset, energy) group: distortion from 1 to `max`,
/// or area ratio from `1/max` to `max`, log scale. One scale per group keeps the solvers'
/// maps comparable; adapting it to the group keeps near-perfect maps (authalic maps often
/// stay within 1%) from rendering as a flat color.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ColorScale {
    pub(super) measure: Measure,
    pub(super) max: f64,
}

impl ColorScale {
    /// The smallest step covering 99% of the triangles of all `values` (flips excluded).
    pub(super) fn fit(measure: Measure, values: &[&[Shade]]) -> ColorScale {
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
    pub(super) fn t(&self, v: f64) -> f64 {
        match self.measure {
            Measure::Distortion => v.ln() / self.max.ln(),
            Measure::AreaRatio => 0.5 + 0.5 * v.ln() / self.max.ln(),
        }
    }

    pub(super) fn ramp(&self, t: f64) -> [u8; 3] {
        match self.measure {
            Measure::Distortion => ramp(&YLORRD, t),
            Measure::AreaRatio => ramp(&RDBU, t),
        }
    }

    pub(super) fn flipped(&self) -> [u8; 3] {
        match self.measure {
            Measure::Distortion => FLIPPED_DISTORTION,
            Measure::AreaRatio => FLIPPED_AREA,
        }
    }

    pub(super) fn color(&self, shade: Shade) -> [u8; 3] {
        match shade {
            Some(v) if !v.is_finite() => UNDEFINED,
            Some(v) => self.ramp(self.t(v)),
            None => self.flipped(),
        }
    }

    /// Color bar ticks (value, label) at 5 evenly spaced positions, the ends open-ended.
    pub(super) fn ticks(&self) -> Vec<(f64, String)> {
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
    pub(super) fn labels(&self) -> (&'static str, &'static str) {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
