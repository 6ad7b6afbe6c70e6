//! mapbench: run every solver variant over a mesh corpus from one TOML config, record
//! per-iteration CSVs and a summary (docs/src/reference/cli.md). Each verb is a function of
//! its own module; this file parses the command line and hands the verb over.

use anyhow::Result;
use clap::Parser;
use std::process::ExitCode;

mod args;
mod book_pages;
mod claims;
mod corpus;
mod gate;
mod history;
mod inspect;
mod provenance;
mod references;
mod run;
mod stdout;
mod submit;
mod systems;

use args::{Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(code) => code,
        // `mapbench list datasets | head`: the reader has what it wanted.
        Err(e) if is_closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Run(a) => run::run(a),
        Command::Submit(a) => submit::verb(a),
        Command::References(a) => references::references(a),
        Command::Report(a) => run::report(a),
        Command::Merge(a) => run::merge(a),
        Command::History(a) => history::history(a),
        Command::ExportSystem(a) => systems::export_system(a),
        Command::Map(a) => inspect::map(a),
        Command::TimeSystem(a) => systems::time_system(a),
        Command::Check(a) => gate::check(a),
        Command::Compare(a) => gate::compare(a),
        Command::Baseline(a) => gate::baseline(a),
        Command::Validate(a) => inspect::validate(a),
        Command::Evaluate(a) => inspect::evaluate(a),
        Command::Corpus(a) => corpus::corpus(a),
        Command::Provenance(a) => provenance::print(&a.run_dirs),
        Command::Claims(a) => claims::claims(a),
        Command::List(a) => inspect::list(a),
        Command::Sandbox => Ok(ExitCode::from(mapbench::external::sandbox::supervise())),
        Command::Confine { rules, command } => {
            Ok(ExitCode::from(mapbench::external::confine::become_solver(&rules, &command)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use std::path::{Path, PathBuf};

    fn repo() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// The committed page at `rel` is `text`; `MAPBENCH_BLESS_DOCS=1` writes it instead.
    fn check_page(rel: &str, text: &str) {
        let path = repo().join(rel);
        if std::env::var_os("MAPBENCH_BLESS_DOCS").is_some() {
            std::fs::write(&path, text).unwrap();
            return;
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == text,
            "{rel} is not what the code generates: rerun with MAPBENCH_BLESS_DOCS=1 (cargo test --release --bin \
             mapbench reference) and commit it"
        );
    }

    #[test]
    fn the_cli_definitions_are_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn reference_pages_are_what_the_code_generates() {
        check_page("docs/src/reference/cli.md", &book_pages::cli_markdown(Cli::command()));
        check_page("docs/src/reference/solvers.md", &book_pages::solvers_markdown());
    }
}
