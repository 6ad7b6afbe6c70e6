//! What every plot draws into: plotters' font (registered once) and the PNG encoding of the
//! RGB buffer.

use anyhow::{Context, Result};
use plotters::style::FontStyle;
use std::sync::Once;

/// plotters has no system fonts here (no `ttf` feature): register the embedded DejaVu once.
pub(super) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Only fails on a malformed font, and the embedded one is fixed at build time.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Encode an RGB buffer as PNG.
pub(super) fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>> {
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
