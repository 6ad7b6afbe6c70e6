//! Paths compared and linked before they exist: made absolute lexically.

use std::path::{Component, Path, PathBuf};

/// `path` made absolute against the current directory, `.` and `..` resolved lexically (the
/// paths compared may not exist yet).
pub fn absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// The relative link from the folder `from` to the file `to` (both made [`absolute`]).
pub fn relative_link(from: &Path, to: &Path) -> String {
    let (from, to) = (absolute(from), absolute(to));
    let (a, b): (Vec<Component>, Vec<Component>) = (from.components().collect(), to.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(b[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    parts.join("/")
}
