//! `corpus fetch`: the shared mesh corpus installed where `MAPBENCH_MESHES` finds it.

use super::args::{CorpusAction, CorpusArgs};
use anyhow::{Context, Result};
use mapbench::corpus;
use mapbench::plan::registry;
use std::path::PathBuf;
use std::process::ExitCode;

/// `corpus fetch`: exit 0 when every selected file is installed, 1 when the fetch refused
/// (a mismatch, a missing source, a cut download: nothing installed), 2 for a bad request.
pub(crate) fn corpus(a: CorpusArgs) -> Result<ExitCode> {
    let CorpusArgs { action: CorpusAction::Fetch, to, from, only, manifest } = a;
    let manifest = manifest.as_deref();
    let Some(to) = to.or_else(|| std::env::var_os(registry::MESHES_ENV).map(PathBuf::from)) else {
        anyhow::bail!("give --to DIR, or set {} to the folder to install into", registry::MESHES_ENV);
    };
    let manifest = match manifest {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
            corpus::Manifest::parse(&text, path)?
        }
        None => corpus::Manifest::built_in()?,
    };
    let entries = manifest.select(&only)?;
    std::fs::create_dir_all(&to).with_context(|| format!("{}: cannot create", to.display()))?;
    let from = match from {
        Some(dir) => corpus::From::Copy(dir),
        None => corpus::From::Sources {
            url: std::env::var(corpus::URL_ENV).unwrap_or_else(|_| corpus::DEFAULT_URL.to_string()),
        },
    };
    match corpus::fetch(&entries, &to, &from, &mut |line| eprintln!("{line}")) {
        Ok(done) => {
            eprintln!(
                "{} files installed, {} present already, in {}: `{}={}` runs the configs that name them",
                done.installed.len(),
                done.present.len(),
                to.display(),
                registry::MESHES_ENV,
                to.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            Ok(ExitCode::from(1))
        }
    }
}
