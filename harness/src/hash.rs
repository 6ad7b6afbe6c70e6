//! The one hash of the harness: run keys, reference keys, batch hashes and map checksums.

use anyhow::{Context, Result};
use std::path::Path;

/// 64-bit FNV-1a: stable across builds and platforms (unlike `DefaultHasher`).
pub struct Fnv(pub u64);

impl Default for Fnv {
    fn default() -> Fnv {
        Fnv::new()
    }
}

impl Fnv {
    pub fn new() -> Fnv {
        Fnv(0xcbf29ce484222325)
    }

    fn byte(&mut self, b: u8) {
        self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x100000001b3);
    }

    /// `b`, then a separator byte.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Fnv {
        b.iter().for_each(|&x| self.byte(x));
        // Separator, so that ("ab", "c") and ("a", "bc") differ.
        self.byte(0xff);
        self
    }

    /// A file's content, as [`Fnv::bytes`].
    pub fn file(&mut self, path: &Path) -> Result<&mut Fnv> {
        let data = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        Ok(self.bytes(&data))
    }

    /// The 8 little-endian bytes of `x`, without a separator (fixed-width words need none).
    pub fn word(&mut self, x: u64) -> &mut Fnv {
        x.to_le_bytes().into_iter().for_each(|b| self.byte(b));
        self
    }
}
