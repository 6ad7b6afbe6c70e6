//! Names that become file names (dataset, energy and solver names are file-name safe:
//! docs/src/design/testing.md, "Bad input"). Every run writes
//! `<dataset>__<energy>__<solver>.csv` and friends inside the run folder, so a name with a
//! separator, `..` or a control character would write elsewhere or produce an unusable file
//! name. Names are checked once, where the config and the registry
//! are loaded; nothing downstream re-checks them.

use thiserror::Error;

/// Longest run name `<dataset>__<energy>__<solver>` in bytes. File names are limited to 255
/// bytes (Linux, macOS, NTFS); the longest name a writer derives from a run name is the
/// temporary of its map plot, `.<run>__map.png.tmp<pid>` (run + 24 bytes with a 7-digit pid),
/// and export-system's `<run>__it<K>.rhs.mtx`; 200 leaves room for both.
pub const MAX_RUN_NAME_BYTES: usize = 200;

/// Characters refused besides separators and control characters: reserved in file names on
/// Windows, and `*`, `?` are the globs of `--only`.
const RESERVED: &[char] = &[':', '*', '?', '"', '<', '>', '|'];

/// A name that cannot be part of a file name.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("{kind} name {name:?} {reason} (names become file and folder names: reports/<name>/, <dataset>__<energy>__<solver>.csv)")]
pub struct NameError {
    pub kind: &'static str,
    pub name: String,
    pub reason: String,
}

/// Check one dataset, energy or solver name (`kind` says which, for the message).
pub fn check_name(kind: &'static str, name: &str) -> Result<(), NameError> {
    let fail = |reason: String| Err(NameError { kind, name: name.to_string(), reason });
    if name.is_empty() {
        return fail("is empty".into());
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return fail(format!("contains the control character U+{:04X}", c as u32));
    }
    if name.contains(['/', '\\']) {
        return fail("contains a path separator".into());
    }
    if name.contains("..") {
        return fail("contains '..'".into());
    }
    if name.starts_with('.') {
        return fail("starts with '.' (hidden files; mapbench's temporaries start with '.')".into());
    }
    if let Some(c) = name.chars().find(|c| RESERVED.contains(c)) {
        return fail(format!("contains '{c}' (not allowed in file names on every system; * and ? are --only globs)"));
    }
    if name.contains("__") {
        return fail("contains '__', the separator of <dataset>__<energy>__<solver>".into());
    }
    if name.trim() != name {
        return fail("starts or ends with white space".into());
    }
    if name.len() > MAX_RUN_NAME_BYTES {
        return fail(format!("is {} bytes long (at most {MAX_RUN_NAME_BYTES})", name.len()));
    }
    Ok(())
}

/// Check that every run name of `datasets` x `energies` x `solvers` fits in a file name: the
/// longest of each is enough. The error names the dataset to shorten.
pub fn check_run_names<'a>(
    datasets: impl IntoIterator<Item = &'a str>,
    energies: &[String],
    solvers: &[String],
) -> Result<(), NameError> {
    let longest = |v: &[String]| v.iter().map(String::len).max().unwrap_or(0);
    let suffix = 4 + longest(energies) + longest(solvers);
    for d in datasets {
        let len = d.len() + suffix;
        if len > MAX_RUN_NAME_BYTES {
            return Err(NameError {
                kind: "dataset",
                name: d.to_string(),
                reason: format!(
                    "makes run names of {len} bytes with this config's energies and solvers (at most \
                     {MAX_RUN_NAME_BYTES} fit in a file name with the suffixes mapbench adds); shorten it to \
                     {} bytes",
                    MAX_RUN_NAME_BYTES.saturating_sub(suffix)
                ),
            });
        }
    }
    Ok(())
}

/// The name and file stem of a run: `<dataset>__<energy>__<solver>`.
pub fn run_stem(dataset: &str, energy: &str, solver: &str) -> String {
    format!("{dataset}__{energy}__{solver}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordinary_names_pass() {
        for n in ["bumpy_1k", "aphrodite", "kp-newton", "exp-sd", "camel head 2", "planar_bar_release_2k", "ü"] {
            assert_eq!(check_name("dataset", n), Ok(()), "{n}");
        }
    }

    #[test]
    fn unsafe_names_are_refused_with_the_reason() {
        let long = "x".repeat(MAX_RUN_NAME_BYTES + 1);
        for (n, reason) in [
            ("", "is empty"),
            ("../../ESCAPED", "path separator"),
            ("..", "'..'"),
            ("a..b", "'..'"),
            ("/abs/x", "path separator"),
            ("a/b", "path separator"),
            ("a\\b", "path separator"),
            ("a\nb", "U+000A"),
            ("tab\there", "U+0009"),
            ("nul\0", "U+0000"),
            (".hidden", "starts with '.'"),
            ("C:x", "':'"),
            ("star*", "'*'"),
            ("a__b", "'__'"),
            (" padded", "white space"),
            (long.as_str(), "bytes long"),
        ] {
            let e = check_name("dataset", n).expect_err(n);
            let msg = e.to_string();
            assert!(msg.contains(reason), "{n:?}: {msg}");
            assert!(msg.starts_with("dataset name "), "{msg}");
        }
    }

    #[test]
    fn run_names_are_bounded_by_the_longest_energy_and_solver() {
        let e = vec!["sd".to_string(), "exp-sd".to_string()];
        let s = vec!["kp-newton-noscale".to_string(), "cm".to_string()];
        let fits = "d".repeat(MAX_RUN_NAME_BYTES - 4 - 6 - 17);
        assert_eq!(check_run_names([fits.as_str()], &e, &s), Ok(()));
        let over = format!("{fits}d");
        let err = check_run_names(["ok", over.as_str()], &e, &s).unwrap_err();
        assert_eq!(err.name, over);
        assert!(err.to_string().contains(&format!("shorten it to {} bytes", fits.len())), "{err}");
    }
}
