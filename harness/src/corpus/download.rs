//! One source file over HTTP(S) into a download folder, resumable: the bytes go to
//! `<sha256>.part` and a fetch that was cut asks for the rest with a `Range` request; the
//! whole file is checked against its pinned size and SHA-256 before it is renamed to
//! `<sha256>`, and a file that is not the pinned one is deleted and refused. The client is
//! `ureq` (blocking, rustls with the Mozilla roots built in: no system TLS library needed).

use super::sha256::sha256_file;
use anyhow::{bail, Context, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How long a connection or a read may stall before the fetch gives up (and can resume).
const STALL: Duration = Duration::from_secs(60);

/// The file of `url` in `dir`, downloaded unless it is there already; `bytes` and `sha256`
/// are what it must be. `say` gets the progress lines.
pub fn fetch_file(url: &str, dir: &Path, bytes: u64, sha256: &str, say: &mut dyn FnMut(&str)) -> Result<PathBuf> {
    let done = dir.join(sha256);
    if std::fs::metadata(&done).is_ok_and(|m| m.len() == bytes) && sha256_file(&done)? == sha256 {
        return Ok(done);
    }
    let part = dir.join(format!("{sha256}.part"));
    let have = std::fs::metadata(&part).map(|m| m.len()).unwrap_or(0).min(bytes);
    if have < bytes {
        get(url, &part, have, bytes, say)?;
    }
    let size = std::fs::metadata(&part).map(|m| m.len()).unwrap_or(0);
    let got = sha256_file(&part)?;
    if size != bytes || got != sha256 {
        let _ = std::fs::remove_file(&part);
        bail!(
            "{url}: the download has SHA-256 {got} ({size} bytes), but the corpus pins {sha256} ({bytes} bytes): \
             not the pinned file, refused (deleted; nothing installed)"
        );
    }
    std::fs::rename(&part, &done).with_context(|| format!("{}: cannot rename into place", done.display()))?;
    Ok(done)
}

/// Bytes `have..bytes` of `url` appended to `part` (the whole file when the server ignores
/// the range).
fn get(url: &str, part: &Path, have: u64, bytes: u64, say: &mut dyn FnMut(&str)) -> Result<()> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_connect(Some(STALL))
        .timeout_per_read(Some(STALL))
        .build()
        .into();
    let mut request = agent.get(url);
    if have > 0 {
        request = request.header("Range", format!("bytes={have}-"));
    }
    let response = request.call().map_err(|e| anyhow::anyhow!("{url}: cannot download: {e}"))?;
    let status = response.status().as_u16();
    let from = match status {
        206 => have,
        200 => 0,
        404 | 410 => bail!("{url}: the source is missing (HTTP {status}): refused, nothing installed"),
        _ => bail!("{url}: the server answered HTTP {status}: nothing installed"),
    };
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .append(from > 0)
        .truncate(from == 0)
        .open(part)
        .with_context(|| format!("{}: cannot write", part.display()))?;
    let total = mb(bytes);
    match from {
        0 => say(&format!("downloading {url} ({total})")),
        _ => say(&format!("resuming {url} at {} of {total}", mb(from))),
    }
    let mut body = response.into_body().into_reader();
    let mut buf = vec![0u8; 1 << 16];
    let (mut at, mut told) = (from, from);
    loop {
        let n = match body.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) => bail!(
                "{url}: the download stopped after {} of {total} ({e}); run the command again to resume it",
                mb(at)
            ),
        };
        if at + n as u64 > bytes {
            drop(file);
            let _ = std::fs::remove_file(part);
            bail!("{url}: the server sends more than the pinned {total}: not the pinned file, refused (nothing installed)");
        }
        file.write_all(&buf[..n]).with_context(|| format!("{}: cannot write", part.display()))?;
        at += n as u64;
        // a line per quarter of a large file
        if bytes >= 4 << 20 && at - told >= bytes / 4 && at < bytes {
            say(&format!("{} of {total}", mb(at)));
            told = at;
        }
    }
    file.flush().with_context(|| format!("{}: cannot write", part.display()))?;
    if at < bytes {
        bail!("{url}: the server sent {} of {total}; run the command again to resume it", mb(at));
    }
    Ok(())
}

fn mb(bytes: u64) -> String {
    match bytes {
        0..=999_999 => format!("{} KB", bytes.div_ceil(1000)),
        _ => format!("{:.1} MB", bytes as f64 / 1e6),
    }
}
