//! From a config and the dataset registry to the runs of a batch: the config is resolved once
//! into a [`Plan`], and every verb (`run`, `export-system`, `meta.json`, `--resume` keys,
//! `merge`'s checks) consumes the plan instead of reading config sections.

pub mod balance;
pub mod config;
pub mod external;
pub mod handles;
pub mod paths;
pub mod registry;
pub mod resolved_starts;
pub mod select;
pub mod settings;
pub mod shard_plan;
pub mod starts;

use anyhow::{bail, Context, Result};
use config::LoadedConfig;
use registry::Dataset;
use select::glob_match;
use std::time::Duration;

pub use config::Task;
pub use settings::RunSettings;

/// The resolved settings of each energy of a config, in the config's order.
pub fn energy_settings(cfg: &LoadedConfig) -> Result<Vec<(String, RunSettings)>> {
    let c = &cfg.config;
    c.energy_names()
        .into_iter()
        .map(|e| c.run_settings(&e).map(|s| (e, s)))
        .collect::<Result<_>>()
        .with_context(|| format!("{}: invalid config", cfg.path.display()))
}

/// One run of the batch.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedRun {
    /// Index into [`Plan::datasets`].
    pub dataset: usize,
    pub energy: String,
    pub solver: String,
    /// `<dataset>__<energy>__<solver>`: the run's file names.
    pub stem: String,
    /// The energy's settings with the options of this run's solver only
    /// ([`RunSettings::for_solver`]).
    pub settings: RunSettings,
    /// The pair is outside the solver's definition: the run is recorded as `skipped` with
    /// this reason and not solved ([`RunSettings::skip_reason`]).
    pub skip: Option<String>,
}

/// A config resolved into the runs of a batch.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The config as read, for provenance (`meta.json`); nothing else reads its sections.
    pub config: LoadedConfig,
    pub task: Task,
    pub datasets: Vec<Dataset>,
    /// One line per registry entry that was skipped, and why.
    pub notices: Vec<String>,
    /// The runs in canonical order (datasets, then energies, then solvers, as the config
    /// lists them), after `--only`.
    pub runs: Vec<PlannedRun>,
    /// The `--only` globs that selected `runs` (empty: every run).
    pub only: Vec<String>,
    /// Wall-clock limit of each run.
    pub timeout: Option<Duration>,
    /// rayon threads inside each run, when the config fixes them.
    pub threads_per_run: Option<usize>,
    /// Times each run is repeated (`repeat`, or `--repeat`), at least 1.
    pub repeat: usize,
    /// Which runs are repeated (`repeat_runs`).
    pub repeat_runs: config::RepeatRuns,
    /// The history database the batch is appended to (`history`, `--history`); `None` with
    /// `--no-history`.
    pub history: Option<std::path::PathBuf>,
    /// Which final maps the run folder keeps.
    pub maps: config::Maps,
    /// The solvers whose maps `best` keeps besides the best (`maps_keep`).
    pub maps_keep: Vec<String>,
    /// The solvers the report shows apart when they leave problems unsolved
    /// (`expected_to_fail`).
    pub expected_to_fail: Vec<String>,
    /// The tolerances of the convergence test, loosest first (`targets`, and an energy's own
    /// `[energy.<name>] targets`), for every task.
    pub targets: crate::convergence::Targets,
    /// Where reference minima are looked up and added (every task).
    pub references: Option<paths::Stores>,
    /// The chained starts resolved so far (`judge::reference::chained`).
    pub starts: resolved_starts::Starts,
}

impl Plan {
    /// Resolve `cfg` with its registry (read from disk) and keep the runs `only` selects.
    pub fn resolve(cfg: LoadedConfig, only: &[String]) -> Result<Plan> {
        let (datasets, notices) =
            registry::resolve(&cfg).with_context(|| format!("{}: datasets", cfg.path.display()))?;
        Plan::with_datasets(cfg, datasets, notices, only)
    }

    /// The plan over datasets already resolved (the fuzz target passes the inline ones, so
    /// nothing is read from disk). An `only` that selects no run is an error.
    pub fn with_datasets(
        cfg: LoadedConfig,
        datasets: Vec<Dataset>,
        notices: Vec<String>,
        only: &[String],
    ) -> Result<Plan> {
        let c = &cfg.config;
        let settings = energy_settings(&cfg)?;
        let mut runs = Vec::new();
        for (d, ds) in datasets.iter().enumerate() {
            for (energy, settings) in &settings {
                for solver in &c.solvers {
                    let stem = crate::names::run_stem(&ds.name, energy, solver);
                    if only.is_empty() || only.iter().any(|g| glob_match(g, &stem)) {
                        let settings = settings.for_solver(solver, &c.solver);
                        let skip = match c.external.get(solver) {
                            Some(declared) => declared.skip_reason(solver, energy, settings.has_smoothness()),
                            None => settings.skip_reason(solver),
                        };
                        runs.push(PlannedRun {
                            dataset: d,
                            energy: energy.clone(),
                            solver: solver.clone(),
                            stem,
                            skip,
                            settings,
                        });
                    }
                }
            }
        }
        if runs.is_empty() {
            bail!("--only {} selects no run of {}", only.join(" "), cfg.path.display());
        }
        // A declaration alone runs nothing: say so rather than leave the solver silently out.
        let mut notices = notices;
        notices.extend(c.external.keys().filter(|name| !c.solvers.contains(name)).map(|name| {
            format!("external solver {name} is declared ([external.{name}]) but not in `solvers`: it does not run")
        }));
        let invalid = || format!("{}: invalid config", cfg.path.display());
        let timeout = c.timeout_secs().with_context(invalid)?.map(Duration::from_secs_f64);
        let repeat = c.repeat.unwrap_or(1);
        config::check_repeat(repeat).with_context(invalid)?;
        let history = Some(paths::resolve_path(c.history.as_deref(), &cfg.dir));
        let targets = c.targets().with_context(invalid)?;
        let references = Some(paths::Stores::of(&cfg));
        Ok(Plan {
            targets,
            references,
            repeat,
            repeat_runs: c.repeat_runs.unwrap_or_default(),
            history,
            maps: c.maps.unwrap_or_default(),
            maps_keep: c.maps_keep.clone().unwrap_or_default(),
            expected_to_fail: c.expected_to_fail.clone().unwrap_or_default(),
            task: c.task,
            threads_per_run: c.threads_per_run,
            config: cfg,
            datasets,
            notices,
            runs,
            only: only.to_vec(),
            timeout,
            starts: resolved_starts::Starts::default(),
        })
    }

    /// The dataset of a run.
    pub fn dataset(&self, run: &PlannedRun) -> &Dataset {
        &self.datasets[run.dataset]
    }

    /// The declaration of a run's solver when it is external (`[external.<name>]`).
    pub fn external(&self, run: &PlannedRun) -> Option<&crate::plan::external::Declared> {
        self.config.config.external.get(&run.solver)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use solvers::energy::{EnergyKind, Sd};
    use std::path::Path;

    fn plan(text: &str, only: &[&str]) -> Result<Plan> {
        let cfg = LoadedConfig::parse(text, Path::new("t.toml"))?;
        let datasets = registry::resolve_inline(&cfg, &[])?;
        let only: Vec<String> = only.iter().map(|s| s.to_string()).collect();
        Plan::with_datasets(cfg, datasets, Vec::new(), &only)
    }

    const INLINE: &str = "name = \"t\"\nenergies = [\"sd\", \"sarap\"]\nsolvers = [\"kp-newton\", \"cm\"]\n\
        [[dataset]]\nname = \"a\"\npath = \"a.obj\"\n[[dataset]]\nname = \"b\"\npath = \"b.obj\"\n";

    #[test]
    fn runs_come_in_canonical_order_with_their_resolved_settings() {
        let p = plan(&format!("{INLINE}[energy.sd]\nsmoothness = 0.25\n[stop]\nmax_iters = 7\n"), &[]).unwrap();
        let stems: Vec<&str> = p.runs.iter().map(|r| r.stem.as_str()).collect();
        assert_eq!(
            stems,
            [
                "a__sd__kp-newton",
                "a__sd__cm",
                "a__sarap__kp-newton",
                "a__sarap__cm",
                "b__sd__kp-newton",
                "b__sd__cm",
                "b__sarap__kp-newton",
                "b__sarap__cm"
            ]
        );
        let RunSettings::Param { energy, settings } = &p.runs[0].settings else { panic!("{:?}", p.runs[0]) };
        assert_eq!(*energy, EnergyKind::Sd(Sd));
        assert_eq!(settings.smoothness, Some((0.25, solvers::smoothness::Projection::Analytic)));
        assert_eq!(settings.solver.stop.max_iters, 7);
        let RunSettings::Param { settings, .. } = &p.runs[2].settings else { panic!() };
        assert_eq!((settings.smoothness, settings.solver.stop.energy_decrease_tol), (None, 1e-8));
        assert_eq!(energy_settings(&p.config).unwrap().len(), 2);
    }

    #[test]
    fn only_filters_and_an_empty_selection_is_an_error() {
        let p = plan(INLINE, &["b__*__cm"]).unwrap();
        assert_eq!(p.runs.iter().map(|r| r.stem.as_str()).collect::<Vec<_>>(), ["b__sd__cm", "b__sarap__cm"]);
        assert_eq!(p.dataset(&p.runs[0]).name, "b");
        let e = format!("{:#}", plan(INLINE, &["zzz*"]).unwrap_err());
        assert!(e.contains("--only zzz* selects no run of t.toml"), "{e}");
    }

    #[test]
    fn an_external_solver_declared_but_not_named_in_solvers_is_a_notice() {
        let ext = "[external.my-gd]\ncommand = [\"python3\", \"gd.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n";
        let p = plan(&format!("{INLINE}{ext}"), &[]).unwrap();
        assert_eq!(
            p.notices,
            ["external solver my-gd is declared ([external.my-gd]) but not in `solvers`: it does not run"]
        );
        assert!(p.runs.iter().all(|r| r.solver != "my-gd"));
        let named = INLINE.replace("\"cm\"]", "\"cm\", \"my-gd\"]");
        let p = plan(&format!("{named}{ext}"), &[]).unwrap();
        assert!(p.notices.is_empty(), "{:?}", p.notices);
        assert_eq!(p.runs.iter().filter(|r| r.solver == "my-gd").count(), 4);
    }

    #[test]
    fn deform_and_authalic_runs_carry_their_task_settings() {
        let d = plan(
            &format!("task = \"deform\"\n{}[deform]\nlambda = 50.0\n", INLINE.replace("\"sarap\"", "\"nh\"")),
            &[],
        )
        .unwrap();
        let RunSettings::Deform { settings, .. } = &d.runs[0].settings else { panic!() };
        assert_eq!((settings.lambda, settings.solver.stop.grad_tol), (50.0, 1e-6));
        let a = plan(
            "name = \"a\"\ntask = \"authalic\"\nsolvers = [\"sem\"]\n[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n\
             [stop]\nmax_iters = 9\n",
            &[],
        )
        .unwrap();
        assert_eq!(a.runs.len(), 1);
        assert_eq!((a.runs[0].energy.as_str(), a.runs[0].settings.task()), ("authalic", Task::Authalic));
        assert_eq!(a.runs[0].settings.stop().max_iters, 9);
        assert!(a.timeout.is_none());
    }

    /// A pair outside the solver's declared energies, or with parameters its builder refuses,
    /// is a planned run marked skipped with the reason (not a config error); the opt-in
    /// brings slim's back.
    #[test]
    fn pairs_outside_a_solvers_definition_are_planned_as_skipped_with_the_reason() {
        let text =
            "name = \"t\"\nenergies = [\"sd\", \"nh\", \"bconf\"]\nsolvers = [\"kp-newton\", \"slim\", \"cm\"]\n\
            [energy.bconf]\nk = 1.5\n[[dataset]]\nname = \"a\"\npath = \"a.obj\"\n";
        let p = plan(text, &[]).unwrap();
        let skipped: Vec<(&str, &str)> =
            p.runs.iter().filter_map(|r| r.skip.as_deref().map(|why| (r.stem.as_str(), why))).collect();
        assert_eq!(skipped.iter().map(|s| s.0).collect::<Vec<_>>(), ["a__nh__slim", "a__bconf__slim", "a__bconf__cm"]);
        assert_eq!(
            skipped[0].1,
            "slim is not defined for nh: its reweighting assumes the per-triangle minimum is a rotation, and many of \
             its weights would be clamped (set [solver.slim] clamp_weights = true to run it with clamped weights)"
        );
        assert!(skipped[2].1.starts_with("cm: bconf with k = 1.5 is not convex"), "{}", skipped[2].1);
        // the opt-in runs slim everywhere; cm's refusal stays
        let p = plan(&format!("{text}[solver.slim]\nclamp_weights = true\n"), &[]).unwrap();
        let skipped: Vec<&str> = p.runs.iter().filter(|r| r.skip.is_some()).map(|r| r.stem.as_str()).collect();
        assert_eq!(skipped, ["a__bconf__cm"]);
        // slim's option is in slim's runs and in the energy's settings, not in the other runs
        let options = |stem: &str| {
            let run = p.runs.iter().find(|r| r.stem == stem).unwrap();
            let RunSettings::Param { settings, .. } = &run.settings else { panic!() };
            settings.solver.options.get("clamp_weights").and_then(|v| v.as_bool()) == Some(true)
        };
        assert!(options("a__nh__slim") && !options("a__nh__kp-newton") && !options("a__nh__cm"));
        assert!(p.runs[1].settings.key_text().contains("\"clamp_weights\":true"), "{}", p.runs[1].settings.key_text());
        let key = |stem: &str| p.runs.iter().find(|r| r.stem == stem).unwrap().settings.key_text();
        let before = plan(text, &[]).unwrap();
        let key_before = |stem: &str| before.runs.iter().find(|r| r.stem == stem).unwrap().settings.key_text();
        assert_eq!(key("a__sd__kp-newton"), key_before("a__sd__kp-newton"));
        assert_ne!(key("a__sd__slim"), key_before("a__sd__slim"));
        // the authalic task has nothing to skip
        let a = plan(
            "name = \"a\"\ntask = \"authalic\"\nsolvers = [\"sem\", \"aem-cg\"]\n[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n",
            &[],
        )
        .unwrap();
        assert!(a.runs.iter().all(|r| r.skip.is_none()));
    }
}
