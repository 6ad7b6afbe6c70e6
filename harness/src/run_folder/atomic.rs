//! Writing a file of a run folder: atomically (a temporary file, then rename), so an interrupted
//! batch never leaves a half-written file; through a link, a FIFO or a device.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Write `bytes` to `path`: atomically (a temporary file in the same folder, then rename) when
/// `path` is new or a regular file; through it when it is a symlink, a FIFO, a character
/// device or a socket, which a rename would replace (a link broken and its target never
/// written; as root, `/dev/stdout` replaced by a file). A link is written through whatever
/// it points to (`/dev/stdout` to the open standard output, not to the file behind it).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(_) if path.is_dir() => bail!("{}: is a folder", path.display()),
        Ok(m) if !m.is_file() => return write_through(path, bytes),
        _ => {}
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create folder", dir.display()))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp{}", std::process::id()));
    // Errors name `path`, the file the caller asked for; a failed write leaves no temporary.
    let written = std::fs::write(&tmp, bytes)
        .with_context(|| format!("{}: cannot write (temporary file {})", path.display(), tmp.display()))
        .and_then(|()| {
            std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot rename into place", path.display()))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// Open `path` for writing (following links, creating a missing target) and write `bytes`.
fn write_through(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(path)
        .with_context(|| format!("{}: cannot open for writing", path.display()))?;
    f.write_all(bytes).and_then(|()| f.flush()).with_context(|| format!("{}: cannot write", path.display()))
}
