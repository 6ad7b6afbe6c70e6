//! mapbench: run every solver variant over a mesh corpus from one TOML config, record
//! per-iteration CSVs and a summary (design.md "CLI").

use anyhow::{Context, Result};
use clap::Parser;
use config::LoadedConfig;

use mapbench::gate::{check, compare};
use mapbench::history::{self, HistoryChoice};
use mapbench::output::Output;
use mapbench::plan::shard_plan::ShardPlanFile;
use mapbench::plan::Plan;
use mapbench::plan::{config, registry};
use mapbench::run::{self, merge, progress};
use mapbench::{export, report, run_folder, signals, slurm};
use std::path::PathBuf;
use std::process::ExitCode;

mod args;
mod provenance;
mod reference;
mod submit;

use args::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Say what became of the batch in the history. `false` when it could not be appended (a
/// warning: the run folder is complete either way; the command exits 2). A trend page that
/// could not be rendered is a warning of its own: the batch is in the history.
fn say_history(outcome: &history::Outcome) -> bool {
    use history::Outcome;
    match outcome {
        Outcome::Off => true,
        Outcome::NotAppended { reason, .. } => {
            eprintln!("note: not appended to the history: {reason}");
            true
        }
        Outcome::Failed { error, .. } => {
            eprintln!("warning: history not updated: {error} (the run folder is complete)");
            false
        }
        Outcome::AlreadyIn { db, batch_id, .. } => {
            eprintln!(
                "history: already in {} as batch {batch_id} (appended by an earlier batch of this folder); not \
                 appended again",
                db.display()
            );
            true
        }
        Outcome::Appended { db, batch_id, runs, config, trend, trend_error } => {
            eprintln!("history: batch {batch_id} ({runs} runs of {config}) appended to {}", db.display());
            match (trend, trend_error) {
                (Some(page), _) => eprintln!("history: trend page {}", page.display()),
                (None, e) => eprintln!(
                    "warning: the trend page was not rendered: {} (`mapbench history --db {} --config {config} \
                     --out DIR` renders it)",
                    e.as_deref().unwrap_or("?"),
                    db.display()
                ),
            }
            true
        }
    }
}

/// `history --fail-on-regression`: what changed in `config`'s latest batch since the one
/// before it, as `check` prints it; exit 1 on a regression, 2 when runs went missing.
fn latest_changes(h: &history::HistoryDb, config: &str) -> Result<ExitCode> {
    let Some(latest) = h.batches(Some(config), Some(1))?.pop() else {
        anyhow::bail!("no batch of config {config:?} in {}", h.path().display());
    };
    match report::changes::since_previous(h, config, latest.id)? {
        Some(report::changes::Since::Previous(ch)) => {
            let settings = if ch.settings_differ() {
                "note: the two batches ran different configs or plans (config hash differs): changes may come \
                 from the settings, not the code\n"
            } else {
                ""
            };
            out(format_args!(
                "batch {} ({}) since batch {} ({}):\n{settings}{}",
                ch.after.id,
                ch.after.short_revision(),
                ch.before.id,
                ch.before.short_revision(),
                check::render(&ch.comparison)
            ))?;
            // As `check`: 2 when runs of the previous batch are missing, 1 on a regression.
            Ok(ExitCode::from(ch.comparison.exit_code()))
        }
        _ => {
            out(format_args!("batch {} is the first of config {config}: nothing to compare with\n", latest.id))?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

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

/// Writes to stdout; unlike `print!`, a reader that closed the pipe is an error the caller
/// sees (and `main` ends quietly on), not a panic.
fn out(text: std::fmt::Arguments) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout.write_fmt(text)?;
    stdout.flush()?;
    Ok(())
}

fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Run { config, out, only, resume, jobs, shard, shard_plan, repeat, force, history } => {
            // External solvers run through this binary's `sandbox` verb.
            if let Ok(me) = std::env::current_exe() {
                mapbench::external::sandbox::use_sandbox(me);
            }
            // First, before any thread starts: every thread inherits the blocked signals.
            let interrupt = Arc::new(AtomicBool::new(false));
            let signal = signals::on_interrupt(interrupt.clone());
            config::check_jobs(jobs, config::available_cores())?;
            let plan = run_plan(&config, &only, repeat, &history.choice(), shard.is_some())?;
            let out = out.unwrap_or_else(|| PathBuf::from("reports").join(&plan.config.config.name));
            let shard_runs = match (&shard_plan, shard) {
                (Some(file), Some(shard)) => {
                    Some(ShardPlanFile::read(file)?.runs_of(shard, &plan).with_context(|| file.display().to_string())?)
                }
                _ => None,
            };
            let opts = run::RunOptions { resume, jobs, shard, shard_runs, force, interrupt };
            let progress = progress::for_stderr();
            let report = run::run_batch(&plan, &out, &opts, progress.as_ref(), &report::Renderer)?;
            say_batch(&report);
            let written = say_history(&report.history);
            // A signal at any moment, after the last run too (the batch is then complete).
            Ok(run_exit(signal.load(Ordering::SeqCst), written, report.failed))
        }
        Command::Submit {
            config,
            shards,
            out,
            only,
            repeat,
            cpus_per_task,
            sbatch,
            dry_run,
            wait,
            resume,
            history,
        } => match (resume, config, shards) {
            (Some(dir), _, _) => {
                if history.history.is_some() || history.no_history {
                    anyhow::bail!("--history and --no-history are the submission's: not with --resume");
                }
                submit::submit_resume(&dir, (!sbatch.is_empty()).then_some(sbatch), wait)
            }
            (None, Some(config), Some(shards)) => {
                let request = slurm::Request {
                    config,
                    shards,
                    out,
                    only,
                    repeat,
                    cpus_per_task,
                    sbatch,
                    history: history.choice(),
                };
                submit::submit(&request, dry_run, wait)
            }
            _ => anyhow::bail!("give CONFIG and --shards N, or --resume DIR"),
        },
        Command::References { config, only, store, from, recertify } => {
            references(&config, &only, store, &from, recertify)
        }
        Command::ExportSystem { config, out, only, iteration } => {
            let cfg = LoadedConfig::load(&config)?;
            // Before the registry: a config of another task is refused for what it is.
            export::check_task(&cfg)?;
            let plan = Plan::resolve(cfg, &only)?;
            mapbench::output::check_folder(&out)?;
            for n in &plan.notices {
                eprintln!("{n}");
            }
            let files = export::export_systems(&plan, iteration, &out)?;
            eprintln!("wrote {} systems to {}", files.len(), out.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::TimeSystem { matrix, ordering, repeat, threads, kernel } => {
            let ordering = match ordering {
                OrderingArg::Metis => solvers::ordering::Ordering::Metis,
                OrderingArg::Amd => solvers::ordering::Ordering::Amd,
            };
            let sys = export::read_matrix_market(&matrix)?;
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads.into()).build()?;
            let t = pool
                .install(|| export::time_system(&sys, ordering, repeat, kernel == KernelArg::Faer))
                .with_context(|| matrix.display().to_string())?;
            out(format_args!("{}\n", serde_json::to_string(&t)?))?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Map { run_dir, runs, obj, out } => map(&run_dir, &runs, obj, out.as_deref()),
        Command::Report { run_dir } => {
            let rows = run_folder::read_summary(&run_dir)?;
            report::refresh(&run_dir, &rows)?;
            eprintln!("report of {} runs in {}", rows.len(), run_dir.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Merge { shards, out, force, history } => merge(&shards, out.as_deref(), force, &history.choice()),
        Command::History { db, config, last, out, fail_on_regression } => {
            if last == Some(0) {
                anyhow::bail!("--last must be at least 1");
            }
            mapbench::output::check_folder(&out)?;
            let h = history::HistoryDb::open_existing(&db)?;
            let page = report::trend::render(&h, config.as_deref(), last, &out)?;
            eprintln!("trend page of {} batches ({} plots): {}", page.batches, page.plots.len(), page.index.display());
            match config.filter(|_| fail_on_regression) {
                Some(config) => latest_changes(&h, &config),
                None => Ok(ExitCode::SUCCESS),
            }
        }
        Command::Check { run_dir, baseline } => {
            let base = check::Baseline::load(&baseline)?;
            let cmp = check::compare(&base, &check::read_summary(&run_dir)?);
            out(format_args!("{}", check::render(&cmp)))?;
            Ok(ExitCode::from(cmp.exit_code()))
        }
        Command::Compare { run_a, run_b, html, energy_rtol, iterations_tolerance, time_regressions } => {
            let options = compare::Options { energy_rtol, iterations_tolerance, time_regressions };
            compare_folders(&run_a, &run_b, html, options)
        }
        Command::Baseline { run_dir, write } => {
            let write = Output::from(write);
            write.check()?;
            let base = check::make_baseline(&run_dir)?;
            let json = serde_json::to_string_pretty(&base)? + "\n";
            write.write(json.as_bytes())?;
            eprintln!("wrote {} runs to {write}", base.runs.len());
            Ok(ExitCode::SUCCESS)
        }
        Command::Validate { mesh, task } => {
            let mesh = match mesh.strip_prefix("generated:") {
                Some(g) => solvers::generate::generate(g)?,
                None => solvers::mesh::load_obj(std::path::Path::new(&mesh))?,
            };
            // The check the run of that task makes, so the two cannot disagree.
            let report = solvers::mesh::validate_for(&mesh, task);
            out(format_args!("{report}\n"))?;
            Ok(if report.is_ok() { ExitCode::SUCCESS } else { ExitCode::from(1) })
        }
        Command::List { what, registry, markdown } => list(what, &registry, markdown),
        Command::Provenance { run_dirs } => provenance::print(&run_dirs),
        Command::Corpus { action: CorpusAction::Fetch, to, from, only, manifest } => {
            corpus_fetch(to, from, &only, manifest.as_deref())
        }
        Command::Sandbox => Ok(ExitCode::from(mapbench::external::sandbox::supervise())),
        // exit 0 whatever the map's quality: the numbers say it
        Command::Evaluate { mesh, map, task, energy, params, frame, config, dataset, json } => {
            let energy = mapbench::evaluate::energy_of(task, &energy, &params)?;
            let known = config.as_deref().zip(dataset.as_deref());
            let score = mapbench::evaluate::evaluate(&mesh, &map, energy, frame, known)?;
            match json {
                true => out(format_args!("{}\n", serde_json::to_string_pretty(&score)?))?,
                false => out(format_args!("{}", score.lines()))?,
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The plan of `run`: the config resolved with `--only`, `--repeat` and the history choice.
fn run_plan(
    config: &std::path::Path,
    only: &[String],
    repeat: Option<usize>,
    choice: &HistoryChoice,
    sharded: bool,
) -> Result<Plan> {
    let mut plan = Plan::resolve(LoadedConfig::load(config)?, only)?;
    if let Some(r) = repeat {
        mapbench::plan::config::check_repeat(r).context("--repeat")?;
        plan.repeat = r;
    }
    plan.history = plan.history.take().and_then(|p| choice.apply(p));
    if *choice == HistoryChoice::Off {
        // Nothing outside the run folder: the references it computes stay its own.
        plan.references.iter_mut().for_each(|r| r.persist = false);
    }
    if sharded && plan.history.take().is_some() {
        eprintln!("note: a --shard batch is not appended to the history; `merge` appends the whole batch");
    }
    Ok(plan)
}

/// The line `run` ends with: how the batch's runs ended and where the results are.
fn say_batch(report: &run::BatchReport) {
    eprintln!(
        "{} runs: {} ok, {}{} not converged, {} failed{}{}; results in {}",
        report.runs,
        report.ok,
        if report.budget > 0 { format!("{} at their budget, ", report.budget) } else { String::new() },
        report.not_converged,
        report.failed,
        if report.skipped > 0 { format!(", {} skipped", report.skipped) } else { String::new() },
        match (report.interrupted - report.partial.len(), report.partial.len()) {
            (0, 0) => String::new(),
            (n, 0) => format!(", {n} not run (interrupted)"),
            (n, p) => format!(", {p} cut short in their repeats and {n} not run (interrupted)"),
        },
        report.out_dir.display()
    );
}

/// `references`: compute the reference minima no store holds yet, lower them with the maps of
/// the run folders `from`, and list them.
fn references(
    config: &std::path::Path,
    only: &[String],
    store: Option<PathBuf>,
    from: &[PathBuf],
    recertify: bool,
) -> Result<ExitCode> {
    let interrupt = Arc::new(AtomicBool::new(false));
    let signal = signals::on_interrupt(interrupt.clone());
    let mut plan = Plan::resolve(LoadedConfig::load(config)?, only)?;
    let Some(stores) = plan.references.as_mut() else {
        anyhow::bail!("{}: the config has no reference stores", config.display());
    };
    if let Some(p) = store {
        stores.store = p;
    }
    let store = stores.store.clone();
    for n in &plan.notices {
        eprintln!("{n}");
    }
    let runs: Vec<&mapbench::plan::PlannedRun> = plan.runs.iter().collect();
    let progress = progress::for_stderr();
    let notice = |line: &str| progress.notice(line);
    let mut groups = mapbench::judge::reference::prepare(&plan, &runs, &notice, &interrupt)?;
    if !from.is_empty() {
        let dirs: Vec<&std::path::Path> = from.iter().map(|p| p.as_path()).collect();
        let candidates = mapbench::judge::improve::from_folders(&plan, &groups, &dirs)?;
        mapbench::judge::improve::improve(&plan, &runs, &mut groups, candidates, &notice, &interrupt)?;
    }
    if recertify {
        mapbench::judge::reference::recertify(&plan, &runs, &mut groups, &notice, &interrupt)?;
    }
    progress.finish();
    println!("dataset\tenergy\te_star\tcertified\torigin\tkey");
    for g in &groups {
        let e = g.e_star.map_or_else(|| "-".to_string(), |e| format!("{e:.15e}"));
        let certified = if g.e_star.is_none() {
            "-"
        } else if g.certified {
            "yes"
        } else {
            "no"
        };
        println!("{}\t{}\t{e}\t{certified}\t{:?}\t{}", g.dataset, g.energy, g.origin, g.key.as_deref().unwrap_or("-"));
    }
    let missing = groups.iter().filter(|g| g.e_star.is_none()).count();
    let uncertified = groups.iter().filter(|g| g.e_star.is_some() && !g.certified).count();
    use mapbench::judge::reference::Origin;
    let from = |o: &[Origin]| groups.iter().filter(|g| g.e_star.is_some() && o.contains(&g.origin)).count();
    eprintln!(
        "{} references: {} from the committed store, {} from {}, {} computed or lowered now \
         ({missing} not available, {uncertified} not certified)",
        groups.len(),
        from(&[Origin::Seed]),
        from(&[Origin::Store]),
        store.display(),
        from(&[Origin::Computed, Origin::Improved]),
    );
    let signalled = signal.load(Ordering::SeqCst);
    if signalled != 0 {
        return Ok(ExitCode::from(128 + signalled.clamp(1, 127) as u8));
    }
    Ok(if missing > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

/// `list`: the solvers, energies or datasets.
fn list(what: ListWhat, registry: &std::path::Path, markdown: bool) -> Result<ExitCode> {
    if markdown && !matches!(what, ListWhat::Solvers) {
        anyhow::bail!("--markdown lists the solvers only");
    }
    match what {
        ListWhat::Solvers if markdown => out(format_args!("{}", reference::solvers_markdown()))?,
        // Every task's solvers, from the one catalogue.
        ListWhat::Solvers => {
            for s in solvers::solver::catalogue::SOLVERS {
                let tasks: Vec<&str> = s.tasks.iter().map(|t| t.as_str()).collect();
                out(format_args!("{:<20} tasks={:<14} energies={}\n", s.name, tasks.join(","), s.energies.join(",")))?;
                out(format_args!("{:<20} {}\n", "", s.description))?;
            }
        }
        ListWhat::Energies => {
            for s in solvers::energy::ENERGY_NAMES {
                out(format_args!("{s}\n"))?;
            }
        }
        ListWhat::Datasets => {
            let reg = registry::Registry::load(registry)
                .with_context(|| "run from the repository root or pass --registry FILE")?;
            for e in &reg.dataset {
                let src =
                    e.generator.as_ref().map(|g| format!("generated:{g}")).unwrap_or_else(|| {
                        format!("${}/{}", registry::MESHES_ENV, e.file.as_deref().unwrap_or_default())
                    });
                out(format_args!(
                    "{:<20} {:<36} tasks={} tags={}\n",
                    e.name,
                    src,
                    e.tasks.join(","),
                    e.tags.join(",")
                ))?;
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `map`: a run folder's stored final maps as OBJ.
fn map(
    run_dir: &std::path::Path,
    runs: &[String],
    obj: Option<PathBuf>,
    out: Option<&std::path::Path>,
) -> Result<ExitCode> {
    let obj = obj.map(Output::from);
    let dest = match (&obj, &out) {
        (Some(f), _) => export::maps::Dest::File(f),
        (None, Some(d)) => export::maps::Dest::Folder(d),
        (None, None) => anyhow::bail!("give --obj FILE or --out DIR"),
    };
    let done = export::maps::export_maps(run_dir, runs, dest)?;
    for p in &done.written {
        eprintln!("{p}");
    }
    if !done.missing.is_empty() {
        eprintln!("no stored map for {}: {}", done.missing.join(", "), export::maps::missing_hint(run_dir));
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}

/// `merge`: shard folders of one batch into one folder.
fn merge(shards: &[PathBuf], out: Option<&std::path::Path>, force: bool, history: &HistoryChoice) -> Result<ExitCode> {
    let m = merge::merge(shards, out, history, force, &report::Renderer)?;
    if !m.missing.is_empty() {
        eprintln!(
            "warning: {} planned runs are in no shard (first: {}); the report covers the rest",
            m.missing.len(),
            m.missing[0]
        );
    }
    for d in &m.interrupted {
        eprintln!("warning: shard {} was interrupted (`run --resume` completes it)", d.display());
    }
    eprintln!("merged {} runs from {} shards into {}", m.runs, shards.len(), m.out_dir.display());
    let written = say_history(&m.history);
    let complete = m.missing.is_empty() && m.interrupted.is_empty();
    Ok(if complete && written { ExitCode::SUCCESS } else { ExitCode::from(2) })
}

/// `compare`: what changed from one run folder to another, as Markdown and optionally HTML.
fn compare_folders(
    run_a: &std::path::Path,
    run_b: &std::path::Path,
    html: Option<PathBuf>,
    options: compare::Options,
) -> Result<ExitCode> {
    let html = html.map(Output::from);
    if let Some(h) = &html {
        h.check()?;
    }
    let cmp = compare::compare_folders(run_a, run_b, options)?;
    // `--html -`: the page on standard output instead of the Markdown.
    if html.as_ref() != Some(&Output::Stdout) {
        out(format_args!("{}", report::compare::to_markdown(&cmp)))?;
    }
    if let Some(h) = html {
        h.write(report::compare::to_html(&cmp).as_bytes())?;
        eprintln!("wrote the comparison page to {h}");
    }
    Ok(ExitCode::from(cmp.exit_code()))
}

/// The exit code of `run`: a signal first, then a result not written to the history, then
/// a failed run.
fn run_exit(signalled: i32, written: bool, failed: usize) -> ExitCode {
    if signalled != 0 {
        // The shell's convention: 128 + the signal (130 Ctrl-C, 143 SIGTERM).
        ExitCode::from(128 + signalled.clamp(1, 127) as u8)
    } else if !written {
        ExitCode::from(2)
    } else if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// `corpus fetch`: exit 0 when every selected file is installed, 1 when the fetch refused
/// (a mismatch, a missing source, a cut download: nothing installed), 2 for a bad request.
fn corpus_fetch(
    to: Option<PathBuf>,
    from: Option<PathBuf>,
    only: &[String],
    manifest: Option<&std::path::Path>,
) -> Result<ExitCode> {
    use mapbench::corpus;
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
    let entries = manifest.select(only)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use std::path::Path;

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
        check_page("docs/src/reference/cli.md", &reference::cli_markdown(Cli::command()));
        check_page("docs/src/reference/solvers.md", &reference::solvers_markdown());
    }
}
