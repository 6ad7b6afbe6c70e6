//! Colors: the solvers' palette of the curve plots and the color scales of the maps.

use plotters::style::RGBColor;

/// The shades of each family of solvers, the family's hue from dark to light (tab10 and
/// ColorBrewer colors), so that the solvers of one family read as related and families apart.
/// Indexed by [`family`].
const FAMILY_SHADES: [&[RGBColor]; 7] = [
    // Newton, analytic projection: blues.
    &[
        RGBColor(31, 119, 180),
        RGBColor(8, 48, 107),
        RGBColor(107, 174, 214),
        RGBColor(23, 190, 207),
        RGBColor(82, 82, 163),
    ],
    // Newton, numeric projection: greens.
    &[RGBColor(44, 160, 44), RGBColor(0, 90, 50), RGBColor(152, 223, 138), RGBColor(188, 189, 34)],
    // Newton, filtered or plain: purples.
    &[RGBColor(148, 103, 189), RGBColor(84, 39, 143), RGBColor(206, 147, 216)],
    // Proxies and majorizers: warm colors.
    &[RGBColor(255, 127, 14), RGBColor(214, 39, 40), RGBColor(140, 86, 75), RGBColor(230, 171, 2)],
    // Quasi-Newton: greys.
    &[RGBColor(127, 127, 127), RGBColor(30, 30, 30), RGBColor(185, 185, 185)],
    // Authalic: teals.
    &[RGBColor(0, 128, 128), RGBColor(102, 194, 165), RGBColor(64, 224, 208)],
    // External solvers and names without a family: pinks.
    &[RGBColor(227, 119, 194), RGBColor(231, 41, 138), RGBColor(174, 1, 126), RGBColor(250, 159, 181)],
];

/// How many marker shapes there are (`chart::draw_marker`).
pub(super) const MARKERS: usize = 8;

/// A solver's look in the plots of one page: its color and marker shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Look {
    pub(super) color: RGBColor,
    pub(super) marker: usize,
}

/// The family index of a solver (a row of [`FAMILY_SHADES`]): its [`crate::family`], the
/// last row for anything else (external solvers). Tables call SLIM with clamped weights
/// `slim (clamped)`: the same family as `slim`.
fn family(solver: &str) -> usize {
    use crate::family::Family;
    let name = solver.strip_suffix(" (clamped)").unwrap_or(solver);
    match crate::family::family(name) {
        Some(Family::AnalyticNewton) => 0,
        Some(Family::NumericNewton) => 1,
        Some(Family::FilteredNewton) => 2,
        Some(Family::Proxy) => 3,
        Some(Family::QuasiNewton) => 4,
        Some(Family::Authalic) => 5,
        None => 6,
    }
}

/// The looks of `solvers` (in the order given, which is the summary's): the k-th solver of a
/// family takes its family's k-th shade and the marker `family + k`, so within a family
/// colors differ (markers too once shades repeat) and the first solvers of different
/// families do not all share one marker.
pub(super) fn looks(solvers: &[&str]) -> Vec<Look> {
    let mut seen = [0usize; FAMILY_SHADES.len()];
    solvers
        .iter()
        .map(|s| {
            let f = family(s);
            let k = seen[f];
            seen[f] += 1;
            let shades = FAMILY_SHADES[f];
            Look { color: shades[k % shades.len()], marker: (f + k) % MARKERS }
        })
        .collect()
}

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

    /// Color bar ticks (value, label) at 5 evenly spaced positions, the ends open-ended, with
    /// as many significant digits (3 to 7) as it takes for no two labels to read alike: a
    /// narrow scale (max 1.01) reads 1, 1.002, 1.005, 1.007, ≥1.01, not 1, 1, 1, 1.01, ≥1.01.
    pub(super) fn ticks(&self) -> Vec<(f64, String)> {
        let (lo, hi) = match self.measure {
            Measure::Distortion => (0.0, 1.0),
            Measure::AreaRatio => (-1.0, 1.0),
        };
        let values: Vec<f64> = (0..5).map(|i| self.max.powf(lo + (hi - lo) * i as f64 / 4.0)).collect();
        let texts = |digits: usize| -> Vec<String> {
            values
                .iter()
                .map(|&v| if (v - 1.0).abs() < 1e-12 { "1".to_string() } else { format_tick(v, digits) })
                .collect()
        };
        let distinct = |t: &[String]| (1..t.len()).all(|i| !t[..i].contains(&t[i]));
        let texts = (3..=7).map(texts).find(|t| distinct(t)).unwrap_or_else(|| texts(7));
        values
            .into_iter()
            .zip(texts)
            .enumerate()
            .map(|(i, (v, text))| {
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

/// `digits` significant digits without trailing zeros (1.05, 0.952, 16 for 3).
fn format_tick(v: f64, digits: usize) -> String {
    let decimals = (digits as i64 - 1 - v.abs().log10().floor() as i64).clamp(0, 9) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 24 solvers (the catalogue's and three external ones): no two alike in color and
    /// marker, colors of different solvers apart by a visible margin, families together.
    #[test]
    fn twenty_four_solvers_look_different_and_families_related() {
        let mut names: Vec<&str> = solvers::tasks::catalogue::SOLVERS.iter().map(|e| e.name).collect();
        names.extend(["igl-slim", "example-gd", "their-newton", "slim (clamped)"]);
        names.truncate(24);
        assert_eq!(names.len(), 24);
        let looks = looks(&names);
        let rgb = |l: &Look| [l.color.0, l.color.1, l.color.2].map(f64::from);
        for i in 0..looks.len() {
            assert_ne!(rgb(&looks[i]), [255.0; 3], "{} drawn white", names[i]);
            for j in 0..i {
                let (a, b) = (rgb(&looks[i]), rgb(&looks[j]));
                let distance = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt();
                assert!(
                    distance > 40.0 || looks[i].marker != looks[j].marker,
                    "{} and {} look alike: {:?} {:?}",
                    names[i],
                    names[j],
                    looks[i],
                    looks[j]
                );
                assert!(distance > 25.0, "{} and {} share a color: {a:?} {b:?}", names[i], names[j]);
            }
        }
        // Families: every kp-newton variant blue, every fp-* green, the externals pink.
        let of = |n: &str| looks[names.iter().position(|x| *x == n).unwrap()].color;
        for n in ["kp-newton", "kp-newton-cg", "kp-newton-noscale"] {
            assert!(FAMILY_SHADES[0].contains(&of(n)), "{n}");
        }
        for n in ["fp-newton-4x4", "fp-newton-6x6", "fp-abs-6x6"] {
            assert!(FAMILY_SHADES[1].contains(&of(n)), "{n}");
        }
        assert!(FAMILY_SHADES[6].contains(&of("igl-slim")));
        assert_eq!(family("slim (clamped)"), family("slim"));
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
        // A narrow scale takes the digits that keep its ticks apart.
        let narrow = ColorScale { measure: Measure::Distortion, max: 1.01 };
        let ticks: Vec<String> = narrow.ticks().into_iter().map(|t| t.1).collect();
        assert_eq!(ticks, ["1", "1.002", "1.005", "1.007", "≥1.01"]);
    }
}
