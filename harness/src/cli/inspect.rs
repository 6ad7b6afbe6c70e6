//! `validate`, `evaluate`, `map` and `list`: meshes, maps and the catalogues, looked at.

use super::args::{EvaluateArgs, ListArgs, ListWhat, MapArgs, ValidateArgs};
use super::stdout::out;
use anyhow::{Context, Result};
use mapbench::export;
use mapbench::output::Output;
use mapbench::plan::registry;
use std::process::ExitCode;

/// `validate`: the topology and degeneracy report of one mesh; exit 1 when it is not usable.
pub(crate) fn validate(a: ValidateArgs) -> Result<ExitCode> {
    let mesh = match a.mesh.strip_prefix("generated:") {
        Some(g) => solvers::generate::generate(g)?,
        None => solvers::mesh::load_obj(std::path::Path::new(&a.mesh))?,
    };
    // The check the run of that task makes, so the two cannot disagree.
    let report = solvers::tasks::validate_for(&mesh, a.task);
    out(format_args!("{report}\n"))?;
    Ok(if report.is_ok() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// `evaluate`: a map made anywhere scored with our code; exit 0 whatever the map's quality
/// (the numbers say it).
pub(crate) fn evaluate(a: EvaluateArgs) -> Result<ExitCode> {
    let energy = mapbench::evaluate::energy_of(a.task, &a.energy, &a.params)?;
    let known = a.config.as_deref().zip(a.dataset.as_deref());
    let score = mapbench::evaluate::evaluate(&a.mesh, &a.map, energy, a.frame, known)?;
    match a.json {
        true => out(format_args!("{}\n", serde_json::to_string_pretty(&score)?))?,
        false => out(format_args!("{}", score.lines()))?,
    }
    Ok(ExitCode::SUCCESS)
}

/// `map`: a run folder's stored final maps as OBJ.
pub(crate) fn map(a: MapArgs) -> Result<ExitCode> {
    let (run_dir, runs, out) = (&a.run_dir, &a.runs, a.out.as_deref());
    let obj = a.obj.map(Output::from);
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

/// `list`: the solvers, energies or datasets.
pub(crate) fn list(a: ListArgs) -> Result<ExitCode> {
    let ListArgs { what, registry, markdown } = a;
    if markdown && !matches!(what, ListWhat::Solvers) {
        anyhow::bail!("--markdown lists the solvers only");
    }
    match what {
        ListWhat::Solvers if markdown => out(format_args!("{}", super::book_pages::solvers_markdown()))?,
        // Every task's solvers, from the one catalogue.
        ListWhat::Solvers => {
            for s in solvers::tasks::catalogue::SOLVERS {
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
            let reg = registry::Registry::load(&registry)
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
