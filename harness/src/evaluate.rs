//! `mapbench evaluate`: a map made anywhere, scored by our own code in our conventions (the
//! mesh centred and scaled to area 1, the energies of `solvers::energy`), so that a number
//! from another code and one from a run are the same number.

use crate::run_folder::map::{self, StoredMesh};
use anyhow::{bail, Context, Result};
use serde::Serialize;
use solvers::energy::EnergyKind;
use solvers::mesh::{obj::load_obj, Mesh};
use solvers::problem::{norm, Evaluation, MapProblem};
use solvers::tasks::Task;
use std::path::Path;

/// The frame a map's coordinates are in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Frame {
    /// The mesh as mapbench normalizes it (area 1): what `run` stores, what `mapbench map`
    /// writes and what an external solver receives.
    Area1,
    /// The mesh in its file's units: the map is scaled with the mesh before it is scored.
    Source,
}

/// What `evaluate` measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Score {
    pub mesh: String,
    pub map: String,
    pub vertices: usize,
    pub faces: usize,
    pub frame: Frame,
    /// The energy with its parameters (`name` and the parameters).
    pub energy: EnergyKind,
    /// The area-weighted energy on the area-1 mesh; `inf` when any face is inverted or
    /// collapsed (every energy here is a barrier).
    pub energy_value: f64,
    /// The Euclidean norm of the energy's gradient in the map's coordinates (area-1 frame);
    /// `None` where the energy is not finite.
    pub grad_norm: Option<f64>,
    /// Faces the map inverts or collapses.
    pub flips: usize,
    /// The smallest signed singular value over the faces (negative: some face is inverted).
    pub sigma_min: f64,
    /// The largest singular value over the faces.
    pub sigma_max: f64,
    /// The reference minimum of the map's problem, when MESH is a run folder's
    /// `meshes/<dataset>.obj.gz` and that batch settled one for this energy.
    pub reference: Option<ReferenceGap>,
}

/// The map's energy against the batch's reference minimum `E*`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceGap {
    pub e_star: f64,
    /// `E - E*`.
    pub above: f64,
    /// `(E - E*) / gap_scale`, on the scale the batch judged its runs (`E0 - E*` of the
    /// common start for `param`): 1 at the start, 0 at the minimum.
    pub gap: Option<f64>,
}

/// Score the map `map_path` of the mesh `mesh_path` with `energy`. The mesh is an OBJ, or a
/// run folder's `meshes/<dataset>.obj.gz`; the map a run folder's `uv/<run>.uv.gz` (which names
/// its mesh by checksum), a text `.uv` (one `u v` line per vertex, as external solvers write)
/// or an OBJ with one `vt` per vertex and the mesh's faces, as `mapbench map` writes.
/// With `known`, the reference minimum is looked up for that config's dataset instead of in
/// the run folder the mesh came from ([`known_reference`]).
pub fn evaluate(
    mesh_path: &Path,
    map_path: &Path,
    energy: EnergyKind,
    frame: Frame,
    known: Option<(&Path, &str)>,
) -> Result<Score> {
    let mesh = read_mesh(mesh_path)?;
    let reference_of = match known {
        Some((config, dataset)) => Some(known_reference(config, dataset, &energy, &mesh)?),
        None => reference(mesh_path, &energy),
    };
    let uv = read_map(map_path, &mesh)?;
    let (_, scale) = mesh.normalization();
    let rest = mesh.normalized();
    let s = match frame {
        Frame::Area1 => 1.0,
        Frame::Source => scale,
    };
    let x: Vec<f64> = uv.iter().flat_map(|p| [p[0] * s, p[1] * s]).collect();
    if let Some(v) = x.iter().position(|c| !c.is_finite()) {
        bail!("{}: vertex {} has a non-finite coordinate", map_path.display(), v / 2);
    }
    let problem = MapProblem::new(&rest, energy).map_err(anyhow::Error::new)?;
    let (energy_value, grad_norm, flips) = measure(&problem, &x);
    let sv = problem.singular_values(&x);
    Ok(Score {
        mesh: mesh_path.display().to_string(),
        map: map_path.display().to_string(),
        vertices: mesh.n_vertices(),
        faces: mesh.n_faces(),
        frame,
        energy,
        energy_value,
        grad_norm,
        flips,
        sigma_min: sv.iter().map(|s| s[1]).fold(f64::INFINITY, f64::min),
        sigma_max: sv.iter().map(|s| s[0]).fold(f64::NEG_INFINITY, f64::max),
        reference: reference_of.map(|(e_star, scale)| ReferenceGap {
            e_star,
            above: energy_value - e_star,
            gap: scale.map(|s| crate::convergence::gap_on(energy_value, e_star, s)),
        }),
    })
}

/// Energy, gradient norm (`None` where the energy is not finite) and flipped faces of the map
/// `x` on `problem`: what `evaluate` and the external solvers' snapshot check measure.
pub fn measure(problem: &MapProblem, x: &[f64]) -> (f64, Option<f64>, usize) {
    let energy = problem.energy(x);
    let grad_norm = energy.is_finite().then(|| {
        let mut ev = Evaluation::default();
        problem.evaluate_without_inertia(x, &mut ev).ok().map(|()| norm(&ev.grad))
    });
    (energy, grad_norm.flatten(), problem.flips(x))
}

/// `E*` and the gap scale of `energy` on the dataset of `<run folder>/meshes/<dataset>.obj.gz`,
/// when that folder's `meta.json` has the reference and ran the energy with these parameters.
fn reference(mesh_path: &Path, energy: &EnergyKind) -> Option<(f64, Option<f64>)> {
    let dataset = mesh_path.file_name()?.to_str()?.strip_suffix(".obj.gz")?;
    let folder = mesh_path.parent().filter(|d| d.file_name().is_some_and(|n| n == "meshes"))?.parent()?;
    let meta = crate::run_folder::meta::Meta::read(folder).ok()?;
    let ran = meta.settings_per_energy.as_ref()?.get(energy.name())?.pointer("/param/energy")?.clone();
    if ran != serde_json::to_value(energy).ok()? {
        return None;
    }
    let groups: Vec<crate::judge::reference::GroupReference> = serde_json::from_value(meta.references?).ok()?;
    let group = groups.iter().find(|g| g.dataset == dataset && g.energy == energy.name())?;
    let e_star = group.e_star?;
    let rows = crate::run_folder::summary::read_summary(folder).ok()?;
    let scale = rows.iter().filter(|r| r.dataset == dataset && r.energy == energy.name()).find_map(|r| r.gap_scale);
    Some((e_star, scale))
}

/// `E*` and the gap scale of `energy` on `dataset` of the batch `config` plans, from its
/// reference stores (the committed `references.json` beside the registry, then the one its
/// batches add to), verified against its stored map: the same key a run of that config looks
/// up, so the energy's parameters and the start's settings are the config's. `mesh` must be
/// the dataset's mesh; the scale is the span the batch judges its runs on.
pub fn known_reference(config: &Path, dataset: &str, energy: &EnergyKind, mesh: &Mesh) -> Result<(f64, Option<f64>)> {
    use crate::plan::{config::LoadedConfig, Plan, RunSettings};
    let only = [crate::names::run_stem(dataset, energy.name(), "*")];
    let plan = Plan::resolve(LoadedConfig::load(config)?, &only)
        .with_context(|| format!("{}: no run of dataset '{dataset}' with {}", config.display(), energy.name()))?;
    let run = &plan.runs[0];
    let RunSettings::Param { energy: planned, .. } = &run.settings else {
        bail!("{}: the reference of a {} batch is not a param map's", config.display(), run.settings.task());
    };
    if planned != energy {
        bail!(
            "{}: its {} is {}, not the energy given ({}): give its parameters with --param",
            config.display(),
            energy.name(),
            serde_json::to_string(planned)?,
            serde_json::to_string(energy)?
        );
    }
    let theirs = plan.dataset(run).load()?;
    if theirs.positions != mesh.positions || theirs.faces != mesh.faces {
        bail!("{}: not the mesh of dataset '{dataset}' ({})", mesh.source, theirs.source);
    }
    let key = crate::judge::reference::key(&plan, run)?;
    let stores = plan.references.as_ref().context("no reference stores")?;
    let mut book = crate::judge::reference::store::Book::open(stores)?;
    if !crate::judge::reference::chained::stored(&plan, run, &mut book) {
        bail!(
            "{}: the SD minimum {dataset} {} starts from is in no reference store ({} computes it)",
            config.display(),
            energy.name(),
            format_args!("`mapbench references {}`", config.display())
        );
    }
    let problem = crate::judge::problem::Problem::with_mesh(&plan, run, theirs)?;
    let refused = std::cell::RefCell::new(Vec::new());
    let found =
        crate::judge::reference::lookup(&book, &key, &problem, &|why| refused.borrow_mut().push(why.to_string()));
    let Some((r, _, _)) = found else {
        let why = refused.into_inner();
        if why.is_empty() {
            bail!(
                "{}: no reference minimum of {dataset} with {} yet (a batch of this config computes it)",
                config.display(),
                energy.name()
            );
        }
        bail!(
            "{}: no usable reference minimum of {dataset} with {}: {}",
            config.display(),
            energy.name(),
            why.join("; ")
        );
    };
    Ok((r.e_star, Some(crate::convergence::span(problem.e0, r.e_star, problem.ideal))))
}

/// The energy `evaluate` scores with: `name` with the `KEY=VALUE` parameters of `params`
/// (TOML values, as in `[energy.<name>]`), for `task` (only `param` so far: a `deform` map's
/// energy needs its handles, an `authalic` one the disk's own energy).
pub fn energy_of(task: Task, name: &str, params: &[String]) -> Result<EnergyKind> {
    if task != Task::Param {
        bail!("evaluate scores `param` maps so far ({task} needs its handles or the disk's own energy)");
    }
    let mut table = toml::Table::new();
    for p in params {
        let one: toml::Table = format!("{}\n", p.replacen('=', " = ", 1))
            .parse()
            .with_context(|| format!("--param {p}: not KEY=VALUE with a TOML value"))?;
        table.extend(one);
    }
    EnergyKind::from_table(name, &table).map_err(|e| anyhow::anyhow!("--energy {name}: {e}"))
}

fn read_mesh(path: &Path) -> Result<Mesh> {
    if path.extension().is_some_and(|e| e == "gz") {
        let m = map::read_mesh(path)?;
        return Ok(Mesh { source: path.display().to_string(), positions: m.positions, faces: m.faces });
    }
    load_obj(path).map_err(anyhow::Error::new)
}

/// How far a map OBJ's `v` line may be from the mesh's vertex, relative to the mesh's largest
/// coordinate: the round-off of a tool that writes fewer digits than a round trip needs.
const OBJ_POSITION_RTOL: f64 = 1e-9;

/// The map's position of each vertex of `mesh`, checked against it.
fn read_map(path: &Path, mesh: &Mesh) -> Result<Vec<[f64; 2]>> {
    let name = path.display();
    if path.to_string_lossy().ends_with(".uv.gz") {
        let checksum = map::checksum(&mesh.positions, &mesh.faces);
        let stored = StoredMesh { positions: mesh.positions.clone(), faces: mesh.faces.clone(), checksum };
        return map::read_uv(path, &stored).with_context(|| format!("{name}: is it a map of {}?", mesh.source));
    }
    if path.extension().is_some_and(|e| e == "uv") {
        return map::read_uv_text(path, mesh.n_vertices());
    }
    let m = map::read_obj(path)?;
    if m.uv.len() != mesh.n_vertices() {
        bail!("{name}: {} map vertices (`vt`), but {} has {} vertices", m.uv.len(), mesh.source, mesh.n_vertices());
    }
    if m.faces.len() != mesh.n_faces() {
        bail!("{name}: {} faces, but {} has {}", m.faces.len(), mesh.source, mesh.n_faces());
    }
    if let Some(t) = (0..mesh.n_faces()).find(|&t| m.faces[t] != mesh.faces[t]) {
        bail!("{name}: face {t} is not face {t} of {} (a map of another mesh or vertex order?)", mesh.source);
    }
    // Same faces, other positions: a map made for another mesh of the same connectivity.
    let scale = mesh.positions.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs())).max(f64::MIN_POSITIVE);
    let off = |a: &[f64; 3], b: &[f64; 3]| {
        (0..3).any(|k| (a[k] - b[k]).abs() > OBJ_POSITION_RTOL * scale || a[k].is_nan() != b[k].is_nan())
    };
    if let Some(v) = (0..mesh.n_vertices()).find(|&v| off(&m.source[v], &mesh.positions[v])) {
        bail!(
            "{name}: vertex {v} (`v` line {}) is at {:?}, but vertex {v} of {} is at {:?} (a map of another mesh?)",
            v + 1,
            m.source[v],
            mesh.source,
            mesh.positions[v]
        );
    }
    Ok(m.uv)
}

impl Score {
    /// The human-readable lines `evaluate` prints.
    pub fn lines(&self) -> String {
        let grad = self.grad_norm.map_or("- (the energy is not finite)".to_string(), |g| format!("{g:e}"));
        let frame = match self.frame {
            Frame::Area1 => "area-1 frame",
            Frame::Source => "the mesh's own units, scaled with it to area 1",
        };
        format!(
            "mesh    {} ({} vertices, {} faces)\nmap     {} ({frame})\nenergy  {} = {}\n|grad|  {grad}\n\
             flips   {}\nsigma   min {:e}, max {:e}\n{}",
            self.mesh,
            self.vertices,
            self.faces,
            self.map,
            self.energy.name(),
            self.energy_value,
            self.flips,
            self.sigma_min,
            self.sigma_max,
            self.reference.as_ref().map_or(String::new(), |r| format!(
                "E*      {} (the batch's reference): E - E* = {:e}, gap {}\n",
                r.e_star,
                r.above,
                r.gap.map_or("-".to_string(), |g| format!("{g:e}"))
            ))
        )
    }
}
