//! The command line's grammar: every verb, its arguments and their help (clap), which the
//! book's command-line page is generated from (`reference.rs`).

use clap::{Args, Parser, Subcommand, ValueEnum};
use mapbench::history::HistoryChoice;
use mapbench::plan::select::Shard;
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "mapbench", version, about = "Benchmark harness for optimizers of planar piecewise-linear maps")]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Run every (dataset, energy, solver) of a config; exit 1 if any run failed.
    Run(RunArgs),
    /// Run a batch on a Slurm cluster: shards balanced by expected time (the history's past
    /// times, else an estimate) in an array job, then a merge job into --out that appends the
    /// batch to the history once. Prints the job ids; with --wait, exits with the merge's code.
    Submit(SubmitArgs),
    /// Compute the reference minima a config's runs are judged by (param, deform) that no
    /// store holds yet (verified against their maps), lower them with the maps of run folders
    /// (`--from`), and list them all with their certificates; a nightly then starts warm.
    References(ReferencesArgs),
    /// Re-render the tables, plots and index.html of a run folder from its CSVs alone.
    Report(ReportArgs),
    /// Combine the folders of `run --shard I/N` batches into one run folder and report.
    Merge(MergeArgs),
    /// Render the trend page of the history database: per config, energy and solver the mean
    /// iterations and time of each batch, and what changed since the previous batch.
    History(HistoryArgs),
    /// Write the Newton system (Matrix Market) of each selected `param` run of a config at an
    /// iteration, for timing other sparse solvers on it (scripts/bench_linear_solvers.py).
    ExportSystem(ExportSystemArgs),
    /// Write the classic OBJ (source mesh as v, map as vt) of stored final maps of a run
    /// folder, for any OBJ viewer; exit 2 when a selected run's map was not kept.
    Map(MapArgs),
    /// Time mapbench's sparse Cholesky (analyse once; factorize + solve, median of --repeat)
    /// on a Matrix Market file written by export-system; prints one JSON line.
    TimeSystem(TimeSystemArgs),
    /// Compare a run folder with a baseline: exit 1 on a regression (more iterations, higher
    /// final energy, worse status, new flips), 2 when a baseline run is missing.
    Check(CheckArgs),
    /// What changed from run folder A (before) to B (after): per run iterations, status,
    /// final energy and time, as Markdown on stdout. Exit 1 on a regression (the rules of
    /// `check`), 2 when the folders share no run; times are labelled, never gated unless
    /// --time-regressions.
    Compare(CompareArgs),
    /// Write a baseline (JSON) from a run folder's summary.csv.
    Baseline(BaselineArgs),
    /// Print the topology and degeneracy report of one mesh (an OBJ file or generated:<name>);
    /// exit 1 when it is not usable for the task.
    Validate(ValidateArgs),
    /// Score a map made anywhere with our code: energy in our convention (mesh at area 1),
    /// gradient norm, flips, singular values. MESH: an OBJ or a run folder's
    /// meshes/<dataset>.obj.gz; MAP: a run folder's uv/<run>.uv.gz or an OBJ with `vt` (as
    /// `mapbench map` writes).
    Evaluate(EvaluateArgs),
    /// Install the shared mesh corpus where MAPBENCH_MESHES finds it: each mesh from its
    /// public source at the pinned commit (or from a copy, --from), made by the recipe that
    /// made it, every download and every file checked against the SHA-256 corpus.toml pins;
    /// a mismatch or a missing source installs nothing (exit 1), and a fetch run again
    /// resumes.
    Corpus(CorpusArgs),
    /// Print each run folder's provenance as one Markdown line for a Results page: date,
    /// revision, the config and its options, runs and wall time, machine, calibration (all
    /// from its meta.json).
    Provenance(ProvenanceArgs),
    /// Decide the papers' claims (claims/*.toml, built in) over run folders: held, not held
    /// or not measurable, by the paper's own stop rule and by the harness's verdict, with the
    /// paper's numbers beside ours.
    Claims(ClaimsArgs),
    /// List the registered datasets, solvers or energies.
    List(ListArgs),
    /// The process between `run` and an external solver (peers/PROTOCOL.md): reads its spec
    /// on standard input, prints its report. Not for hand use.
    #[command(hide = true)]
    Sandbox,
    /// The solver's process in the sandbox: confines itself by RULES (JSON), then becomes
    /// the command. Not for hand use.
    #[command(hide = true)]
    Confine {
        rules: String,
        #[arg(last = true, required = true)]
        command: Vec<String>,
    },
}

/// `--only`: the runs of a config a verb takes.
#[derive(Args)]
pub(crate) struct Only {
    /// Only the runs whose `<dataset>__<energy>__<solver>` matches this glob (`*`, `?`);
    /// repeat for several.
    #[arg(long = "only", value_name = "GLOB")]
    pub(crate) globs: Vec<String>,
}

#[derive(Args)]
pub(crate) struct RunArgs {
    /// The config file (TOML; see the book's config reference).
    pub(crate) config: PathBuf,
    /// Output folder (default: reports/<name>).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) only: Only,
    /// Reuse the runs a previous batch finished in the same folder with the same code,
    /// settings, mesh and handles (keys in runs/<run>.json); run the rest.
    #[arg(long)]
    pub(crate) resume: bool,
    /// Runs at once (default: the machine's cores; at most 4 x the cores). Each run uses
    /// `threads_per_run` threads inside (config; default: the cores shared among the
    /// runs, 1 while runs outnumber them).
    #[arg(long)]
    pub(crate) jobs: Option<usize>,
    /// Run only shard I of N (1-based): every N-th run of the batch's canonical order.
    /// Give each shard its own --out and combine them with `merge`.
    #[arg(long)]
    pub(crate) shard: Option<Shard>,
    /// With --shard I/N: run the runs shard I of this plan holds (`shards.json`, as `submit`
    /// writes it: shards balanced by expected time) instead of every N-th run.
    #[arg(long, requires = "shard", value_name = "FILE")]
    pub(crate) shard_plan: Option<PathBuf>,
    /// Repeat every run N times, round-robin over the batch (overrides `repeat`);
    /// `time_s` is the median, `time_s_min`/`time_s_max` the spread.
    #[arg(long)]
    pub(crate) repeat: Option<usize>,
    /// Delete the results of another config or plan found in the output folder instead of
    /// refusing to write there (mapbench's own files only).
    #[arg(long, conflicts_with = "resume")]
    pub(crate) force: bool,
    #[command(flatten)]
    pub(crate) history: HistoryDbArgs,
}

#[derive(Args)]
pub(crate) struct SubmitArgs {
    /// The config (not with --resume).
    #[arg(required_unless_present = "resume", conflicts_with = "resume")]
    pub(crate) config: Option<PathBuf>,
    /// Shards (array tasks); at most the batch's runs.
    #[arg(long, required_unless_present = "resume", conflicts_with = "resume")]
    pub(crate) shards: Option<usize>,
    /// The folder the shards are merged into (default: reports/<name>); the submission's
    /// plan, scripts, shard folders and logs go to its slurm/.
    #[arg(long, conflicts_with = "resume")]
    pub(crate) out: Option<PathBuf>,
    /// Only the runs whose `<dataset>__<energy>__<solver>` matches this glob, as `run --only`.
    #[arg(long, conflicts_with = "resume")]
    pub(crate) only: Vec<String>,
    /// Repeat every run N times, as `run --repeat`.
    #[arg(long, conflicts_with = "resume")]
    pub(crate) repeat: Option<usize>,
    /// Cores of each task (`--cpus-per-task`), which its `run --jobs` uses.
    #[arg(long, default_value_t = 1, conflicts_with = "resume")]
    pub(crate) cpus_per_task: usize,
    /// An sbatch argument for every job, e.g. --sbatch=--partition=short --sbatch=--time=2:00:00
    /// (repeat for several); with --resume, instead of the submission's (a longer --time).
    #[arg(long = "sbatch", value_name = "ARG", allow_hyphen_values = true)]
    pub(crate) sbatch: Vec<String>,
    /// Write the plan and the scripts and print the plan; submit nothing.
    #[arg(long, conflicts_with = "resume")]
    pub(crate) dry_run: bool,
    /// Wait for the merge job and exit with its code (2 when a shard failed: the merge never
    /// starts; `--resume` then completes the batch).
    #[arg(long, conflicts_with = "dry_run")]
    pub(crate) wait: bool,
    /// Resubmit the shards of the submission in DIR that are missing or incomplete (a
    /// cancelled or failed task), then the merge.
    #[arg(long, value_name = "DIR")]
    pub(crate) resume: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) history: HistoryDbArgs,
}

#[derive(Args)]
pub(crate) struct ReferencesArgs {
    /// The config file whose runs' reference minima are wanted.
    pub(crate) config: PathBuf,
    #[command(flatten)]
    pub(crate) only: Only,
    /// The store computed references are added to (default: the config's `references`,
    /// else references.json beside its history database). `--store references.json` in
    /// the repository's root refreshes the committed seed.
    #[arg(long)]
    pub(crate) store: Option<PathBuf>,
    /// A run folder of the config whose final maps that end below a reference lower it
    /// (polished and certified first); repeatable.
    #[arg(long, value_name = "DIR")]
    pub(crate) from: Vec<PathBuf>,
    /// Certify the uncertified references again (polishing them further) by today's
    /// rules; an entry that is lower or now certified replaces the stored one.
    #[arg(long)]
    pub(crate) recertify: bool,
}

#[derive(Args)]
pub(crate) struct ReportArgs {
    /// A run folder (`run`'s or `merge`'s output).
    pub(crate) run_dir: PathBuf,
}

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// The shards' run folders (`run --shard I/N` outputs of one batch).
    #[arg(required = true)]
    pub(crate) shards: Vec<PathBuf>,
    /// Output folder (default: reports/<name> of the shards' config).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Replace the results of another config or plan found in the output folder instead of
    /// refusing to write there (mapbench's own files only).
    #[arg(long)]
    pub(crate) force: bool,
    #[command(flatten)]
    pub(crate) history: HistoryDbArgs,
}

#[derive(Args)]
pub(crate) struct HistoryArgs {
    /// The database (default: reports/history.sqlite).
    #[arg(long, default_value = mapbench::plan::paths::DEFAULT_PATH)]
    pub(crate) db: PathBuf,
    /// Only this config's batches (default: every config, one section each).
    #[arg(long)]
    pub(crate) config: Option<String>,
    /// Only the last N batches of each config.
    #[arg(long)]
    pub(crate) last: Option<usize>,
    /// Folder for index.html and plots/.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Print what changed in the config's latest batch since the one before it and exit 1
    /// on a regression, 2 when runs of the previous batch are missing (the rules of
    /// `check`): the nightly's gate.
    #[arg(long, requires = "config")]
    pub(crate) fail_on_regression: bool,
}

#[derive(Args)]
pub(crate) struct ExportSystemArgs {
    /// The config file (`param` task).
    pub(crate) config: PathBuf,
    /// Output folder for `<run>__it<K>.mtx` and `.rhs.mtx`.
    #[arg(long)]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) only: Only,
    /// The iterate whose system is written (0 = the initial map).
    #[arg(long, default_value_t = 0)]
    pub(crate) iteration: usize,
}

#[derive(Args)]
pub(crate) struct MapArgs {
    /// A run folder whose final maps were kept (`maps`).
    pub(crate) run_dir: PathBuf,
    /// Runs as `<dataset>__<energy>__<solver>` or globs (`*`, `?`); default: every run.
    pub(crate) runs: Vec<String>,
    /// Write the one selected run's OBJ to this file (`-`: standard output).
    #[arg(long, conflicts_with = "out", required_unless_present = "out")]
    pub(crate) obj: Option<PathBuf>,
    /// Write `<run>.obj` of every selected run into this folder.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
}

#[derive(Args)]
pub(crate) struct TimeSystemArgs {
    /// A Matrix Market file `export-system` wrote.
    pub(crate) matrix: PathBuf,
    #[arg(long, value_enum, default_value = "metis")]
    pub(crate) ordering: OrderingArg,
    #[arg(long, default_value_t = 5)]
    pub(crate) repeat: usize,
    /// Threads of the factorization and solve (a run's `threads_per_run`).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) threads: u16,
    /// `subtree`: mapbench's factorization and triangular solves, parallel over the
    /// elimination tree (what runs use); `faer`: faer's own factorization, parallel only
    /// inside each supernode, and faer's solves.
    #[arg(long, value_enum, default_value = "subtree")]
    pub(crate) kernel: KernelArg,
}

#[derive(Args)]
pub(crate) struct CheckArgs {
    /// The run folder to check.
    pub(crate) run_dir: PathBuf,
    /// The baseline JSON (`mapbench baseline` writes one).
    #[arg(long)]
    pub(crate) baseline: PathBuf,
}

#[derive(Args)]
pub(crate) struct CompareArgs {
    /// The run folder before.
    pub(crate) run_a: PathBuf,
    /// The run folder after.
    pub(crate) run_b: PathBuf,
    /// Also write the comparison as a self-contained HTML page (`-`: the page on standard
    /// output instead of the Markdown).
    #[arg(long)]
    pub(crate) html: Option<PathBuf>,
    /// Relative tolerance on the final energy.
    #[arg(long, default_value_t = mapbench::gate::rules::DEFAULT_ENERGY_RTOL)]
    pub(crate) energy_rtol: f64,
    /// Allowed increase of a run's iterations before it is a regression.
    #[arg(long, default_value_t = 0)]
    pub(crate) iterations_tolerance: usize,
    /// Count a time flagged slower (beyond the spreads, or the single-sample factor) as a
    /// regression (exit 1).
    #[arg(long)]
    pub(crate) time_regressions: bool,
}

#[derive(Args)]
pub(crate) struct BaselineArgs {
    /// The run folder whose summary becomes the baseline.
    pub(crate) run_dir: PathBuf,
    /// The baseline file (`-`: standard output).
    #[arg(long)]
    pub(crate) write: PathBuf,
}

#[derive(Args)]
pub(crate) struct ValidateArgs {
    /// An OBJ file, or `generated:<name>` for a mesh our code generates.
    pub(crate) mesh: String,
    /// `param` and `authalic` need a topological disk (`authalic` an interior vertex);
    /// `deform` allows holes but needs a planar, counter-clockwise shape.
    #[arg(long, default_value = "param", value_parser = task_parser())]
    pub(crate) task: solvers::tasks::Task,
}

#[derive(Args)]
pub(crate) struct EvaluateArgs {
    /// The mesh: an OBJ, or a run folder's `meshes/<dataset>.obj.gz`.
    pub(crate) mesh: PathBuf,
    /// The map: a run folder's `uv/<run>.uv.gz`, or an OBJ with `vt` lines.
    pub(crate) map: PathBuf,
    /// The task whose energy scores the map (only `param` so far).
    #[arg(long, default_value = "param", value_parser = task_parser())]
    pub(crate) task: solvers::tasks::Task,
    /// The energy (`mapbench list energies`), with its default parameters unless --param.
    #[arg(long, default_value = "sd")]
    pub(crate) energy: String,
    /// A parameter of the energy, KEY=VALUE as in `[energy.<name>]` (repeat for several).
    #[arg(long = "param")]
    pub(crate) params: Vec<String>,
    /// The frame of the map's coordinates.
    #[arg(long, value_enum, default_value = "area1")]
    pub(crate) frame: mapbench::evaluate::Frame,
    /// Look the reference minimum up for this config's dataset (with --dataset) instead of
    /// in the run folder MESH came from.
    #[arg(long, requires = "dataset")]
    pub(crate) config: Option<PathBuf>,
    /// The dataset of --config whose mesh MESH is.
    #[arg(long, requires = "config")]
    pub(crate) dataset: Option<String>,
    /// Print JSON instead of lines.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct CorpusArgs {
    /// What to do: `fetch` installs the corpus.
    #[arg(value_enum)]
    pub(crate) action: CorpusAction,
    /// The folder to install into (default: $MAPBENCH_MESHES).
    #[arg(long, value_name = "DIR")]
    pub(crate) to: Option<PathBuf>,
    /// Take the files from this copy of the corpus (checked alike) instead of their sources.
    #[arg(long, value_name = "DIR")]
    pub(crate) from: Option<PathBuf>,
    /// Only the meshes whose name matches a glob (repeatable), and those they are made from.
    #[arg(long, value_name = "GLOB")]
    pub(crate) only: Vec<String>,
    /// Another corpus manifest (default: the repository's corpus.toml, built in).
    #[arg(long, value_name = "FILE")]
    pub(crate) manifest: Option<PathBuf>,
}

#[derive(Args)]
pub(crate) struct ProvenanceArgs {
    /// Run folders (each with a meta.json).
    #[arg(required = true)]
    pub(crate) run_dirs: Vec<PathBuf>,
}

#[derive(Args)]
pub(crate) struct ClaimsArgs {
    /// Run folders (each with a meta.json naming its config): a claim is answered by the first
    /// folder of a config it names (`configs/papers*.toml` measure them all).
    #[arg(required = true)]
    pub(crate) run_dirs: Vec<PathBuf>,
    /// Print JSON (every claim with its numbers, outcomes and runs) instead of text.
    #[arg(long, conflicts_with = "markdown")]
    pub(crate) json: bool,
    /// Print a Markdown table (the book's Results page).
    #[arg(long)]
    pub(crate) markdown: bool,
}

#[derive(Args)]
pub(crate) struct ListArgs {
    #[arg(value_enum, default_value = "datasets")]
    pub(crate) what: ListWhat,
    /// solvers: the catalogue as the Markdown table of the book's reference page.
    #[arg(long)]
    pub(crate) markdown: bool,
    /// The dataset registry (default: ./datasets.toml).
    #[arg(long, default_value = "datasets.toml")]
    pub(crate) registry: PathBuf,
}

/// Where `run` and `merge` append the batch (the history database).
#[derive(Args)]
pub(crate) struct HistoryDbArgs {
    /// The history database (default: the config's `history`, else reports/history.sqlite).
    #[arg(long, value_name = "PATH")]
    pub(crate) history: Option<PathBuf>,
    /// Do not append this batch to any history database, nor add the reference minima it
    /// computes to the reference store: nothing is written outside the run folder.
    #[arg(long, conflicts_with = "history")]
    pub(crate) no_history: bool,
}

impl HistoryDbArgs {
    pub(crate) fn choice(self) -> HistoryChoice {
        HistoryChoice::from_flags(self.history, self.no_history)
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum OrderingArg {
    Metis,
    Amd,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum KernelArg {
    Subtree,
    Faer,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum CorpusAction {
    /// Install the corpus (what is there with the right SHA-256 is kept).
    Fetch,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum ListWhat {
    Datasets,
    Solvers,
    Energies,
}

/// `--task`: the solvers' `Task`, its names listed in `--help` and in the error.
pub(crate) fn task_parser() -> impl clap::builder::TypedValueParser<Value = solvers::tasks::Task> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(solvers::tasks::Task::ALL.map(|t| t.as_str()))
        .try_map(|s| s.parse::<solvers::tasks::Task>())
}
