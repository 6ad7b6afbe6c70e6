//! The final map of each run, every triangle colored by its distortion (`param`, `deform`) or
//! its area ratio (`authalic`) on a color scale shared by the maps of its group.

use super::canvas::{encode_png, register_font};
use super::colors::{ColorScale, Measure, Shade};
use super::plot::{Plot, PlotKind};
use crate::report::select::is_authalic;
use crate::run_folder::map::{self as mapfile, MapFile};
use crate::run_folder::{run_stem, write_atomic, SummaryRow};
use anyhow::{bail, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use rayon::prelude::*;
use solvers::local::{flatten, signed_area, LocalOp};
use std::path::Path;

/// Map renderings: the map square plus a title and a color bar below it.
pub(super) const MAP_SIZE: (u32, u32) = (500, 540);
/// Edges are drawn only below this many triangles and when triangles cover this many pixels
/// on average; otherwise they would turn the map grey.
const MAX_FACES_WITH_EDGES: usize = 3000;
const MIN_PIXELS_PER_FACE_WITH_EDGES: f64 = 40.0;

/// The map plots of a group's finished `runs` that left a map in `uv/` (either format).
pub(super) fn render_group(run_dir: &Path, (dataset, energy): (&str, &str), runs: &[&SummaryRow]) -> Result<Vec<Plot>> {
    // The dataset's mesh copy, read once for the group's compact maps (and only if one exists).
    let mesh = std::sync::OnceLock::new();
    let mesh_path = mapfile::mesh_path(run_dir, dataset);
    let read_mesh = || match mesh.get_or_init(|| mapfile::read_mesh(&mesh_path).map_err(|e| format!("{e:#}"))) {
        Ok(m) => Ok(m.clone()),
        Err(e) => Err(anyhow::anyhow!("{e}")),
    };
    // Read every map of the group first: they share one color scale.
    let maps = runs
        .par_iter()
        .map(|r| {
            let stem = run_stem(dataset, energy, &r.solver);
            let Some(map) = mapfile::read_with(run_dir, &stem, read_mesh)? else { return Ok(None) };
            // A map with a non-finite coordinate is no result (such a run failed); a folder
            // holding one anyway still gets its report, without that picture.
            if map.uv.iter().flatten().any(|c| !c.is_finite()) {
                return Ok(None);
            }
            let measure = if is_authalic(r) { Measure::AreaRatio } else { Measure::Distortion };
            let values = shades(measure, &map);
            Ok(Some((r.solver.as_str(), stem, map, values, measure)))
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect::<Vec<_>>();
    let Some(measure) = maps.first().map(|m| m.4) else { return Ok(Vec::new()) };
    let scale = ColorScale::fit(measure, &maps.iter().map(|m| m.3.as_slice()).collect::<Vec<_>>());
    maps.par_iter()
        .map(|(solver, stem, map, values, _)| {
            let title = format!("{dataset}, {energy}, {solver}: final map");
            let png =
                render_map(&title, map, values, &scale).with_context(|| format!("map of {stem}: cannot render"))?;
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
        .collect::<Result<Vec<_>>>()
}

/// A face's source triangle, flattened isometrically into its own plane, and its map triangle.
fn corners(map: &MapFile, f: &[usize; 3]) -> ([[f64; 2]; 3], [[f64; 2]; 3]) {
    (flatten(f.map(|v| map.source[v])), f.map(|v| map.uv[v]))
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
            let (z, q) = corners(map, f);
            let Some(op) = LocalOp::from_planar(z) else { return Some(f64::NAN) };
            // The solvers' flip test (`Problem::flips`), so the count matches the summary's.
            if signed_area(q) <= 0.0 {
                return None;
            }
            let [s1, s2] = op.wirtinger(q).singular_values();
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
            let (z, q) = corners(map, f);
            let m = signed_area(q);
            if m <= 0.0 {
                return None;
            }
            Some((m / map_total) / (signed_area(z) / src_total))
        })
        .collect()
}

/// Total source area and total absolute map area.
fn total_areas(map: &MapFile) -> (f64, f64) {
    map.faces.iter().fold((0.0, 0.0), |(s, m), f| {
        let (z, q) = corners(map, f);
        (s + signed_area(z), m + signed_area(q).abs())
    })
}

/// The per-triangle values `measure` colors.
fn shades(measure: Measure, map: &MapFile) -> Vec<Shade> {
    match measure {
        Measure::Distortion => distortion(map),
        Measure::AreaRatio => area_ratios(map),
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
mod tests {
    use super::*;
    use crate::report::plots::colors::{FLIPPED_DISTORTION, UNDEFINED};

    fn one_triangle(source: [[f64; 3]; 3], uv: [[f64; 2]; 3]) -> MapFile {
        MapFile { source: source.to_vec(), uv: uv.to_vec(), faces: vec![[0, 1, 2]] }
    }

    /// Singular values and determinant of a face's Jacobian, as `distortion` gets them.
    fn jacobian_sv(z: [[f64; 2]; 3], q: [[f64; 2]; 3]) -> (f64, f64, f64) {
        let [s1, s2] = LocalOp::from_planar(z).unwrap().wirtinger(q).singular_values();
        (s1, s2, s1 * s2)
    }

    #[test]
    fn similarities_have_distortion_one() {
        // A tilted source triangle, mapped by its own 2D frame turned by 0.7 rad and scaled by 3.
        let src = [[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.2, 1.5, 0.3]];
        let [_, [a, _], [bx, by]] = flatten(src);
        let (c, s, k) = (0.7f64.cos(), 0.7f64.sin(), 3.0);
        let rot = |x: f64, y: f64| [k * (c * x - s * y) + 5.0, k * (s * x + c * y) - 2.0];
        let map = one_triangle(src, [rot(0.0, 0.0), rot(a, 0.0), rot(bx, by)]);
        let (s1, s2, det) = jacobian_sv(flatten(src), [map.uv[0], map.uv[1], map.uv[2]]);
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
        let (a0, a1) = (0.5, signed_area([m2.uv[1], m2.uv[3], m2.uv[2]]));
        let (s0, s1) = (0.5, signed_area([[1.0, 0.0], [1.5, 2.0], [0.3, 1.0]]));
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
    fn a_degenerate_source_triangle_has_no_distortion() {
        // Collinear source corners: no Jacobian, drawn in the undefined color, not as a flip.
        let map = MapFile {
            source: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            uv: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.5], [0.0, 1.0]],
            faces: vec![[0, 1, 2], [0, 1, 3]],
        };
        let d = distortion(&map);
        assert!(d[0].is_some_and(f64::is_nan) && d[1].is_some_and(f64::is_finite), "{d:?}");
        assert_eq!(ColorScale { measure: Measure::Distortion, max: 4.0 }.color(d[0]), UNDEFINED);
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
