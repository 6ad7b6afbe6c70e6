//! The files a verb writes where its user said (`map --obj`, `baseline --write`, `compare
//! --html`) and the folders it fills (`--out` of `map`, `history`, `export-system`): `-` is
//! standard output, a symlink, FIFO or device is written through rather than replaced
//! ([`write_atomic`]), and nothing of a run folder's own is overwritten ([`run_folder::owner`]).

use crate::run_folder::{self, write_atomic};
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// Where a verb writes one file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Output {
    /// `-`.
    Stdout,
    File(PathBuf),
}

impl From<PathBuf> for Output {
    fn from(p: PathBuf) -> Output {
        if p.as_os_str() == "-" {
            Output::Stdout
        } else {
            Output::File(p)
        }
    }
}

impl std::fmt::Display for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Output::Stdout => f.write_str("standard output"),
            Output::File(p) => write!(f, "{}", p.display()),
        }
    }
}

impl Output {
    /// Refuse a run folder's own file before any work is done.
    pub fn check(&self) -> Result<()> {
        match self {
            Output::Stdout => Ok(()),
            Output::File(p) => refuse_own_file(p),
        }
    }

    /// Write `bytes` (checked again: the folder may have become a run folder meanwhile). A
    /// reader that closed standard output is an `io::ErrorKind::BrokenPipe` error.
    pub fn write(&self, bytes: &[u8]) -> Result<()> {
        match self {
            Output::Stdout => {
                use std::io::Write;
                let mut out = std::io::stdout().lock();
                out.write_all(bytes)?;
                out.flush()?;
                Ok(())
            }
            Output::File(p) => {
                refuse_own_file(p)?;
                write_atomic(p, bytes)
            }
        }
    }
}

/// An error when `path` is a file or folder a run folder keeps its results in.
pub fn refuse_own_file(path: &Path) -> Result<()> {
    if let Some(dir) = run_folder::owner(path) {
        bail!(
            "{}: one of the run folder {}'s own files; mapbench does not overwrite them (write elsewhere)",
            path.display(),
            dir.display()
        );
    }
    Ok(())
}

/// An error when the folder a verb fills (`--out`) is a run folder or one of its own folders:
/// its `index.html`, plots or files would replace the batch's.
pub fn check_folder(dir: &Path) -> Result<()> {
    if run_folder::is_run_folder(dir) {
        bail!("{}: a run folder; give this output a folder of its own", dir.display());
    }
    refuse_own_file(dir)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// A run folder with its two marker files, in a fresh temporary folder.
    fn run_folder() -> (tempfile::TempDir, PathBuf) {
        let tmp = tempfile::tempdir().unwrap();
        let b = tmp.path().join("B");
        std::fs::create_dir_all(b.join("runs")).unwrap();
        std::fs::write(b.join("summary.csv"), "x\n").unwrap();
        std::fs::write(b.join("meta.json"), "{}").unwrap();
        (tmp, b)
    }

    #[test]
    fn a_run_folders_own_files_are_refused_and_new_files_beside_them_are_not() {
        let (tmp, b) = run_folder();
        for own in ["summary.csv", "meta.json", "index.html", "runs/x.csv", "plots/p.png"] {
            let e = Output::from(b.join(own)).write(b"y").unwrap_err().to_string();
            assert!(e.contains("own files"), "{own}: {e}");
        }
        assert_eq!(std::fs::read_to_string(b.join("summary.csv")).unwrap(), "x\n");
        // through a link, and by a relative path with `..`
        std::os::unix::fs::symlink(b.join("summary.csv"), tmp.path().join("link")).unwrap();
        assert!(Output::from(tmp.path().join("link")).check().is_err());
        assert!(Output::from(b.join("runs/../summary.csv")).check().is_err());
        assert!(Output::from(b.join("new/../summary.csv")).check().is_err(), "through a folder that is not there");
        // a dangling link into a run folder's own folder
        std::os::unix::fs::symlink(b.join("runs/new.csv"), tmp.path().join("dangling")).unwrap();
        assert!(Output::from(tmp.path().join("dangling")).check().is_err());
        // a new file in the run folder, and anything elsewhere, are fine
        Output::from(b.join("compare.html")).write(b"<p>").unwrap();
        Output::from(tmp.path().join("summary.csv")).write(b"z").unwrap();
        // folders
        assert!(check_folder(&b).is_err() && check_folder(&b.join("plots")).is_err());
        assert!(check_folder(&b.join("objs")).is_ok() && check_folder(tmp.path()).is_ok());
    }

    #[test]
    fn links_fifos_and_devices_are_written_through_not_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        let (target, link) = (tmp.path().join("target.json"), tmp.path().join("link.json"));
        std::fs::write(&target, "old").unwrap();
        std::os::unix::fs::symlink(&target, &link).unwrap();
        Output::from(link.clone()).write(b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link is kept");
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        // a dangling link creates its target
        let (missing, dangling) = (tmp.path().join("missing.json"), tmp.path().join("dangling.json"));
        std::os::unix::fs::symlink(&missing, &dangling).unwrap();
        Output::from(dangling.clone()).write(b"made").unwrap();
        assert!(std::fs::symlink_metadata(&dangling).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&missing).unwrap(), "made");
        // a character device stays one
        Output::from(PathBuf::from("/dev/null")).write(b"gone").unwrap();
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
        // a FIFO: its reader gets the bytes, and it is still a FIFO
        let fifo = tmp.path().join("fifo");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        Output::from(fifo.clone()).write(b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe");
        assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        // a regular file is still replaced atomically, and a folder is refused
        let plain = tmp.path().join("plain");
        Output::from(plain.clone()).write(b"1").unwrap();
        Output::from(plain.clone()).write(b"2").unwrap();
        assert_eq!(std::fs::read_to_string(&plain).unwrap(), "2");
        assert!(Output::from(tmp.path().to_path_buf()).write(b"x").unwrap_err().to_string().contains("is a folder"));
        assert_eq!(Output::from(PathBuf::from("-")), Output::Stdout);
    }
}
