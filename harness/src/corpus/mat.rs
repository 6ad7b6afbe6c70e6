//! The numeric matrices of a MATLAB 5 MAT-file (little-endian, zlib-compressed elements or
//! not), which is what the corpus's `mat` sources are: enough of the format to read `v` and
//! `f` (MATLAB's "MAT-File Format", level 5). Other variables (cells, structs, sparse,
//! complex) are skipped.

use anyhow::{bail, Context, Result};
use flate2::read::ZlibDecoder;
use std::collections::BTreeMap;
use std::io::Read;

/// A real 2-D matrix, stored column-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    pub rows: usize,
    pub cols: usize,
    pub data: Vec<f64>,
}

impl Matrix {
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.data[i + j * self.rows]
    }
}

const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
/// `mxSPARSE_CLASS` is 5; classes 6..=15 are numeric (double .. uint64).
const NUMERIC_CLASSES: std::ops::RangeInclusive<u8> = 6..=15;

/// The real numeric matrices of a MAT-file, by name.
pub fn read(bytes: &[u8]) -> Result<BTreeMap<String, Matrix>> {
    if bytes.len() < 128 || &bytes[126..128] != b"IM" {
        bail!("not a little-endian MATLAB 5 MAT-file");
    }
    let mut out = BTreeMap::new();
    let mut at = 128;
    while at + 8 <= bytes.len() {
        let (kind, size) = (u32_at(bytes, at), u32_at(bytes, at + 4) as usize);
        let body = bytes.get(at + 8..at + 8 + size).context("an element runs past the end of the file")?;
        match kind {
            MI_COMPRESSED => {
                let mut raw = Vec::new();
                ZlibDecoder::new(body).read_to_end(&mut raw).context("a compressed element does not inflate")?;
                if raw.len() >= 8 && u32_at(&raw, 0) == MI_MATRIX {
                    let n = (u32_at(&raw, 4) as usize).min(raw.len() - 8);
                    matrix(&raw[8..8 + n], &mut out)?;
                }
                at += 8 + size;
            }
            MI_MATRIX => {
                matrix(body, &mut out)?;
                at += 8 + padded(size);
            }
            _ => at += 8 + padded(size),
        }
    }
    Ok(out)
}

/// One miMATRIX element's sub-elements: flags, dimensions, name, real part.
fn matrix(body: &[u8], out: &mut BTreeMap<String, Matrix>) -> Result<()> {
    let mut parts = Vec::new();
    let mut at = 0;
    while at + 8 <= body.len() && parts.len() < 4 {
        let (kind, size, data, next) = element(body, at)?;
        parts.push((kind, size, data));
        at = next;
    }
    let [(_, _, flags), (_, _, dims), (_, _, name), (kind, _, real)] = parts[..] else {
        return Ok(());
    };
    let (class, complex) = (flags.first().copied().unwrap_or(0), flags.get(1).is_some_and(|f| f & 0x08 != 0));
    if !NUMERIC_CLASSES.contains(&class) || complex || dims.len() != 8 {
        return Ok(());
    }
    let (rows, cols) = (i32_at(dims, 0).max(0) as usize, i32_at(dims, 4).max(0) as usize);
    let data = numbers(kind, real)?;
    if data.len() != rows * cols {
        bail!("a {rows}x{cols} matrix with {} values", data.len());
    }
    out.insert(String::from_utf8_lossy(name).into_owned(), Matrix { rows, cols, data });
    Ok(())
}

/// The element at `at`: its type, size, data and where the next one starts (the small
/// format packs up to 4 bytes of data into the tag).
fn element(b: &[u8], at: usize) -> Result<(u32, usize, &[u8], usize)> {
    let first = u32_at(b, at);
    if first >> 16 != 0 {
        let size = (first >> 16) as usize;
        let data = b.get(at + 4..at + 4 + size.min(4)).context("a small element runs past its matrix")?;
        return Ok((first & 0xffff, size, data, at + 8));
    }
    let size = u32_at(b, at + 4) as usize;
    let data = b.get(at + 8..at + 8 + size).context("an element runs past its matrix")?;
    Ok((first, size, data, at + 8 + padded(size)))
}

/// The values of a numeric element as `f64`.
fn numbers(kind: u32, d: &[u8]) -> Result<Vec<f64>> {
    fn each<const N: usize>(d: &[u8], f: impl Fn([u8; N]) -> f64) -> Vec<f64> {
        d.chunks_exact(N).map(|c| f(c.try_into().unwrap_or([0; N]))).collect()
    }
    Ok(match kind {
        1 => each(d, |b: [u8; 1]| i8::from_le_bytes(b) as f64),
        2 => each(d, |b: [u8; 1]| b[0] as f64),
        3 => each(d, |b| i16::from_le_bytes(b) as f64),
        4 => each(d, |b| u16::from_le_bytes(b) as f64),
        5 => each(d, |b| i32::from_le_bytes(b) as f64),
        6 => each(d, |b| u32::from_le_bytes(b) as f64),
        7 => each(d, |b| f32::from_le_bytes(b) as f64),
        9 => each(d, f64::from_le_bytes),
        12 => each(d, |b| i64::from_le_bytes(b) as f64),
        13 => each(d, |b| u64::from_le_bytes(b) as f64),
        _ => bail!("data of MAT type {kind}, which is not numeric"),
    })
}

fn padded(size: usize) -> usize {
    size.div_ceil(8) * 8
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    b.get(at..at + 4).map_or(0, |s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn i32_at(b: &[u8], at: usize) -> i32 {
    u32_at(b, at) as i32
}
