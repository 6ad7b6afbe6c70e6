//! What serde cannot check in a config: names, the solvers of the task (the catalogue),
//! parameters that do not belong to an energy or a task, out-of-range values.

use super::{available_cores, check_repeat, check_threads_per_run, Config, InitConfig, Task};
use anyhow::{bail, Context, Result};
use solvers::energy::ENERGY_NAMES;
use solvers::tasks::authalic::AUTHALIC_ENERGY;
use solvers::tasks::catalogue::{self, names_for};
use solvers::tasks::SolverError;

impl Config {
    /// Checks names and values that serde cannot (unknown solver/energy names, parameters
    /// that do not belong to an energy, out-of-range values).
    pub fn check(&self) -> Result<()> {
        self.timeout_secs()?;
        check_threads_per_run(self.threads_per_run, available_cores())?;
        if let Some(r) = self.repeat {
            check_repeat(r)?;
        }
        self.targets()?;
        self.check_names()?;
        self.check_solver_options()?;
        self.check_maps_keep()?;
        self.check_expected_to_fail()?;
        self.check_task_keys()?;
        if self.task == Task::Authalic {
            return self.check_authalic();
        }
        if self.authalic.is_some() {
            bail!("[authalic] applies only to task = \"authalic\"");
        }
        if self.energies.is_empty() {
            bail!("'energies' is empty: name at least one of {}", ENERGY_NAMES.join(", "));
        }
        self.check_solvers()?;
        if self.datasets.is_empty() && self.dataset.is_empty() {
            bail!("no datasets: give 'datasets = [...]' (names or tag:<tag>) or [[dataset]] entries");
        }
        for e in &self.energies {
            self.energy_kind(e)?;
        }
        for name in self.energy.keys() {
            if !ENERGY_NAMES.contains(&name.as_str()) {
                bail!("[energy.{name}]: unknown energy (known: {})", ENERGY_NAMES.join(", "));
            }
            self.energy_kind(name)?;
        }
        self.check_numbers()
    }

    /// `[deform]`, `[init]` and handles where the task has them.
    fn check_task_keys(&self) -> Result<()> {
        if self.task != Task::Deform && self.deform.is_some() {
            bail!("[deform] applies only to task = \"deform\"");
        }
        if self.task == Task::Deform {
            if self.init != InitConfig::default() {
                bail!("[init] does not apply to task deform (it starts from the rest pose)");
            }
            if let Some(l) = self.deform.as_ref().and_then(|d| d.lambda) {
                if !(l > 0.0 && l.is_finite()) {
                    bail!("[deform] lambda = {l} must be positive and finite");
                }
            }
        }
        for d in &self.dataset {
            crate::plan::handles::check_handles(d.handles.is_some(), d.handles_set, d.handles_rule.as_deref())
                .with_context(|| format!("[[dataset]] '{}'", d.name))?;
            // Handles only mean something to `deform`: silently ignoring them would hide a
            // config that was meant to be a deform batch.
            if self.task != Task::Deform && (d.handles.is_some() || d.handles_rule.is_some()) {
                bail!(
                    "[[dataset]] '{}': handles apply only to task = \"deform\" (this config's task is {}); \
                     remove them or set the task",
                    d.name,
                    self.task.as_str()
                );
            }
        }
        Ok(())
    }

    /// The numeric settings of the stop rule, the start, the line search and the linear
    /// solves are in range.
    fn check_numbers(&self) -> Result<()> {
        let positive = |key: &str, v: Option<f64>| match v {
            Some(x) if !(x > 0.0 && x.is_finite()) => bail!("{key} = {x} must be positive and finite"),
            _ => Ok(()),
        };
        positive("[stop] grad_tol", self.stop.grad_tol)?;
        positive("[init] scaling_jump", self.init.scaling_jump)?;
        if let Some(ls) = &self.line_search {
            positive("[line_search] max_step_fraction", Some(ls.max_step_fraction))?;
            positive("[line_search] armijo_c", Some(ls.armijo_c))?;
            positive("[line_search] min_step", Some(ls.min_step))?;
            if !(ls.shrink > 0.0 && ls.shrink < 1.0) {
                bail!("[line_search] shrink = {} must be in (0, 1)", ls.shrink);
            }
            if ls.armijo_c >= 1.0 {
                bail!("[line_search] armijo_c = {} must be below 1", ls.armijo_c);
            }
        }
        if let Some(t) = self.stop.energy_decrease_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] energy_decrease_tol = {t} must be non-negative");
            }
        }
        if let Some(t) = self.linear.map(|l| l.tikhonov) {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[linear] tikhonov = {t} must be non-negative");
            }
        }
        Ok(())
    }

    /// Names that become file names are file-name safe (`crate::names`), and no list repeats
    /// an entry (a repeated energy or solver would run the same run twice into one file).
    fn check_names(&self) -> Result<()> {
        // `name` is the default run folder, reports/<name>.
        crate::names::check_name("config", &self.name).context("'name'")?;
        for d in &self.dataset {
            crate::names::check_name("dataset", &d.name).context("[[dataset]]")?;
        }
        for e in &self.energies {
            crate::names::check_name("energy", e).context("'energies'")?;
        }
        for s in &self.solvers {
            crate::names::check_name("solver", s).context("'solvers'")?;
        }
        for (name, declared) in &self.external {
            crate::names::check_name("solver", name).context("[external]")?;
            if catalogue::find(name).is_some() {
                bail!("[external.{name}]: '{name}' is a solver of the catalogue; give the external one another name");
            }
            declared.check(name)?;
        }
        let inline: Vec<String> = self.dataset.iter().map(|d| d.name.clone()).collect();
        for (key, list) in [
            ("datasets", &self.datasets),
            ("energies", &self.energies),
            ("solvers", &self.solvers),
            ("[[dataset]] name", &inline),
        ] {
            let mut seen = std::collections::HashSet::new();
            if let Some(dup) = list.iter().find(|x| !seen.insert(x.as_str())) {
                bail!("{key}: '{dup}' appears twice");
            }
        }
        Ok(())
    }

    /// `maps_keep` names solvers of this config, and only with `maps = "best"`.
    fn check_maps_keep(&self) -> Result<()> {
        let Some(keep) = &self.maps_keep else { return Ok(()) };
        let maps = self.maps.unwrap_or_default();
        if maps != super::Maps::Best {
            bail!(
                "maps_keep applies to maps = \"best\" (maps = \"{}\" keeps {} map already)",
                maps.as_str(),
                if maps == super::Maps::All { "every" } else { "no" }
            );
        }
        for s in keep {
            if !self.solvers.contains(s) {
                bail!("maps_keep names {s:?}, not a solver of this config (solvers = [{}])", self.solvers.join(", "));
            }
        }
        Ok(())
    }

    /// `expected_to_fail` names solvers of this config.
    fn check_expected_to_fail(&self) -> Result<()> {
        for s in self.expected_to_fail.iter().flatten() {
            if !self.solvers.contains(s) {
                bail!(
                    "expected_to_fail names {s:?}, not a solver of this config (solvers = [{}])",
                    self.solvers.join(", ")
                );
            }
        }
        Ok(())
    }

    /// Every solver is in the catalogue and runs this config's task.
    fn check_solvers(&self) -> Result<()> {
        if self.solvers.is_empty() {
            bail!("'solvers' is empty: name at least one of {}", names_for(self.task).join(", "));
        }
        for s in &self.solvers {
            if let Some(declared) = self.external.get(s) {
                if !declared.tasks.contains(&self.task) {
                    let tasks: Vec<&str> = declared.tasks.iter().map(|t| t.as_str()).collect();
                    bail!(
                        "[external.{s}] solves {} (its tasks), not this config's task {}",
                        tasks.join(", "),
                        self.task
                    );
                }
                continue;
            }
            match catalogue::lookup(s, self.task) {
                Ok(_) => {}
                Err(e @ SolverError::WrongTask { runs, .. }) => {
                    let tasks: Vec<String> = runs.iter().map(|t| format!("\"{t}\"")).collect();
                    bail!("{e}; it runs in a config with task = {}", tasks.join(" or "))
                }
                Err(e @ SolverError::Unknown { .. }) => {
                    bail!("{e}; a solver outside the catalogue is declared in [external.{s}]")
                }
                Err(e) => bail!("{e}"),
            }
        }
        Ok(())
    }

    /// Every `[solver.<name>]` names a solver of this config's task and reads as that
    /// solver's options (its keys only, its checks).
    fn check_solver_options(&self) -> Result<()> {
        for (name, options) in &self.solver {
            if self.external.contains_key(name) {
                bail!("[solver.{name}]: {name} is an external solver; its settings are in [external.{name}]");
            }
            let entry = catalogue::lookup(name, self.task).map_err(|e| anyhow::anyhow!("[solver.{name}]: {e}"))?;
            entry.check_options(options)?;
        }
        Ok(())
    }

    /// The `authalic` task's rules: one energy, its own solvers, no Newton sections.
    fn check_authalic(&self) -> Result<()> {
        if self.energies.iter().any(|e| e != AUTHALIC_ENERGY) {
            bail!("task authalic has the one energy '{AUTHALIC_ENERGY}' (got {:?}); omit 'energies'", self.energies);
        }
        self.check_solvers()?;
        if self.datasets.is_empty() && self.dataset.is_empty() {
            bail!("no datasets: give 'datasets = [...]' (names or tag:<tag>) or [[dataset]] entries");
        }
        for (section, unused) in [
            ("[line_search]", self.line_search.is_some()),
            ("[linear]", self.linear.is_some()),
            ("[init]", self.init != InitConfig::default()),
            ("[energy.*]", !self.energy.is_empty()),
        ] {
            if unused {
                bail!("{section} does not apply to task authalic (its settings are in [authalic])");
            }
        }
        if let Some(t) = self.stop.energy_decrease_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] energy_decrease_tol = {t} must be non-negative");
            }
        }
        if let Some(t) = self.stop.grad_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] grad_tol = {t} must be non-negative");
            }
        }
        if let Some(a) = &self.authalic {
            for (key, x) in [("alpha0", a.alpha0), ("armijo_c", a.armijo_c), ("wolfe_c2", a.wolfe_c2)] {
                if !(x > 0.0 && x.is_finite()) {
                    bail!("[authalic] {key} = {x} must be positive and finite");
                }
            }
            if a.armijo_c >= 1.0 || a.wolfe_c2 >= 1.0 {
                bail!("[authalic] armijo_c and wolfe_c2 must be below 1");
            }
        }
        Ok(())
    }
}
