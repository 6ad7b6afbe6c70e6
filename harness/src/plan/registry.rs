//! The dataset registry (`datasets.toml`): generated meshes built by our own code and file
//! entries looked up in `MAPBENCH_MESHES`, selected by name or `tag:<tag>`.

use crate::hash::Fnv;
use crate::plan::config::LoadedConfig;
use crate::plan::handles::HandleSource;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::mesh::{load_obj, Mesh};
use std::path::{Path, PathBuf};

/// The environment variable naming the folder of file-based registry entries.
pub const MESHES_ENV: &str = "MAPBENCH_MESHES";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub name: String,
    /// Name of a generated mesh (`solvers::generate`), or ...
    pub generator: Option<String>,
    /// ... an OBJ file name relative to `MAPBENCH_MESHES`.
    pub file: Option<String>,
    /// Tasks the mesh suits (`param`, `deform`, `authalic`).
    #[serde(default)]
    pub tasks: Vec<String>,
    #[serde(default)]
    pub tags: Vec<String>,
    /// Provenance written by `scripts/prepare_datasets.py` (not verified here).
    pub sha256: Option<String>,
    /// Expected vertex and face counts; a file that disagrees fails its runs.
    pub vertices: Option<usize>,
    pub faces: Option<usize>,
    /// `deform`: a `*.p2p.json` handles file relative to `MAPBENCH_MESHES` ...
    pub handles: Option<String>,
    /// ... and the index of its constraint set (default 0);
    pub handles_set: Option<usize>,
    /// or a rule of `solvers::tasks::deform::HANDLE_RULES` (generated shapes bring their own).
    pub handles_rule: Option<String>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Registry {
    #[serde(default)]
    pub dataset: Vec<Entry>,
}

impl Registry {
    pub fn load(path: &Path) -> Result<Registry> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
        Self::parse(&text, path)
    }

    /// A registry from its text; `path` names it in errors. Nothing is read from disk.
    pub fn parse(text: &str, path: &Path) -> Result<Registry> {
        let reg: Registry = toml::from_str(text).with_context(|| format!("{}: invalid registry", path.display()))?;
        let mut seen = std::collections::HashSet::new();
        for e in &reg.dataset {
            check_entry(e).with_context(|| format!("{}: invalid registry", path.display()))?;
            if !seen.insert(e.name.as_str()) {
                bail!("{}: dataset '{}' appears twice", path.display(), e.name);
            }
            match (&e.generator, &e.file) {
                (Some(g), None) => {
                    if !solvers::generate::generated_names().contains(&g.as_str()) {
                        bail!(
                            "{}: dataset '{}': unknown generator '{g}' (known: {})",
                            path.display(),
                            e.name,
                            solvers::generate::generated_names().join(", ")
                        );
                    }
                }
                (None, Some(_)) => {}
                _ => bail!("{}: dataset '{}' needs exactly one of 'generator' and 'file'", path.display(), e.name),
            }
            crate::plan::handles::check_handles(e.handles.is_some(), e.handles_set, e.handles_rule.as_deref())
                .with_context(|| format!("{}: dataset '{}'", path.display(), e.name))?;
        }
        Ok(reg)
    }

    /// Entries selected by names and `tag:<tag>` selectors, in selector order without
    /// repeats. An unknown name or a tag that selects nothing is an error.
    pub fn select(&self, selectors: &[String]) -> Result<Vec<&Entry>> {
        let mut out: Vec<&Entry> = Vec::new();
        for sel in selectors {
            let picked: Vec<&Entry> = if let Some(tag) = sel.strip_prefix("tag:") {
                let v: Vec<&Entry> = self.dataset.iter().filter(|e| e.tags.iter().any(|t| t == tag)).collect();
                if v.is_empty() {
                    bail!("no dataset has tag '{tag}'");
                }
                v
            } else {
                let e = self.dataset.iter().find(|e| &e.name == sel).with_context(|| {
                    format!("unknown dataset '{sel}' (not in the registry; `mapbench list datasets` shows them)")
                })?;
                vec![e]
            };
            for e in picked {
                if !out.iter().any(|o| o.name == e.name) {
                    out.push(e);
                }
            }
        }
        Ok(out)
    }
}

/// A registry entry's name is file-name safe and its files stay inside `MAPBENCH_MESHES`
/// (relative, no `..`): the registry may come from `scripts/prepare_datasets.py` or a user.
fn check_entry(e: &Entry) -> Result<()> {
    crate::names::check_name("dataset", &e.name)?;
    for (key, file) in [("file", &e.file), ("handles", &e.handles)] {
        if let Some(f) = file {
            let p = Path::new(f);
            use std::path::Component::{CurDir, Normal};
            let escapes = p.components().any(|c| !matches!(c, Normal(_) | CurDir));
            if f.is_empty() || escapes || f.chars().any(char::is_control) {
                bail!(
                    "dataset '{}': {key} = {f:?} must be a relative path inside {MESHES_ENV} (no '..', no root, \
                     no control characters)",
                    e.name
                );
            }
        }
    }
    Ok(())
}

/// Where a dataset's mesh comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    Generated(String),
    File(PathBuf),
}

impl MeshSource {
    /// Build or read the mesh. Errors name the file and the cause.
    pub fn load(&self) -> Result<Mesh> {
        match self {
            MeshSource::Generated(g) => Ok(solvers::generate::generate(g)?),
            MeshSource::File(p) => Ok(load_obj(p)?),
        }
    }
}

/// A dataset resolved for a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    pub name: String,
    pub source: MeshSource,
    /// Vertex and face counts the registry expects, if it says.
    pub expected: (Option<usize>, Option<usize>),
    /// Handles of the `deform` task.
    pub handles: HandleSource,
}

impl Dataset {
    /// The initial map a `deform` run starts from when the dataset brings one (a generated
    /// shape's released pose); `None`: the rest pose.
    pub fn initial_map(&self) -> Option<Vec<[f64; 2]>> {
        match &self.source {
            MeshSource::Generated(g) => solvers::generate::generated_init(g),
            MeshSource::File(_) => None,
        }
    }

    /// Hash what a run takes from its dataset into a run's or a reference's key: the mesh (a
    /// file by content), the counts the registry expects, the handles (a file by content).
    pub fn hash_into(&self, h: &mut Fnv) -> Result<()> {
        match &self.source {
            MeshSource::Generated(g) => h.bytes(b"generated").bytes(g.as_bytes()),
            MeshSource::File(p) => h.bytes(b"file").file(p)?,
        };
        h.bytes(format!("{:?}", self.expected).as_bytes());
        match &self.handles {
            HandleSource::None => h.bytes(b"no handles"),
            HandleSource::Generated(g) => h.bytes(b"generated handles").bytes(g.as_bytes()),
            HandleSource::Rule(r) => h.bytes(b"rule").bytes(r.as_bytes()),
            // A missing handles file fails the run anyway: key it by name, not content.
            HandleSource::File { path, set } => match h.bytes(format!("set {set}").as_bytes()).file(path) {
                Ok(h) => h,
                Err(_) => h.bytes(path.display().to_string().as_bytes()),
            },
        };
        Ok(())
    }

    /// Build or read the mesh and check the registry's counts.
    pub fn load(&self) -> Result<Mesh> {
        let mesh = self.source.load()?;
        let (v, f) = self.expected;
        if v.is_some_and(|v| v != mesh.n_vertices()) || f.is_some_and(|f| f != mesh.n_faces()) {
            bail!(
                "{}: has {} vertices and {} faces, the registry entry '{}' expects {} and {}",
                mesh.source,
                mesh.n_vertices(),
                mesh.n_faces(),
                self.name,
                v.map_or("any".into(), |v| v.to_string()),
                f.map_or("any".into(), |f| f.to_string()),
            );
        }
        Ok(mesh)
    }
}

/// The datasets of a config, in order: registry selections, then inline entries. File
/// entries whose folder (`MAPBENCH_MESHES`) is unset or whose file is absent are skipped;
/// the returned notices say which and why (one line each).
pub fn resolve(cfg: &LoadedConfig) -> Result<(Vec<Dataset>, Vec<String>)> {
    let mut out = Vec::new();
    let mut notices = Vec::new();
    if !cfg.config.datasets.is_empty() {
        let path = cfg.registry_path().with_context(|| {
            format!(
                "{}: 'datasets' needs a datasets.toml (none found in the config's folder or above)",
                cfg.path.display()
            )
        })?;
        let reg = Registry::load(&path)?;
        let meshes_dir = std::env::var_os(MESHES_ENV).map(PathBuf::from);
        let mut missing_corpus = false;
        for e in reg.select(&cfg.config.datasets)? {
            let source = match (&e.generator, &e.file) {
                (Some(g), _) => MeshSource::Generated(g.clone()),
                (None, Some(f)) => {
                    let Some(dir) = &meshes_dir else {
                        notices.push(format!("skipping {}: {MESHES_ENV} is not set", e.name));
                        missing_corpus = true;
                        continue;
                    };
                    let p = dir.join(f);
                    if !p.is_file() {
                        notices.push(format!("skipping {}: {} not found", e.name, p.display()));
                        missing_corpus = true;
                        continue;
                    }
                    MeshSource::File(p)
                }
                (None, None) => unreachable!("checked when the registry was loaded"),
            };
            let handles = match (&e.handles, &e.handles_rule, &e.generator) {
                (Some(h), _, _) => match &meshes_dir {
                    Some(dir) => HandleSource::File { path: dir.join(h), set: e.handles_set.unwrap_or(0) },
                    None => HandleSource::None,
                },
                (None, Some(r), _) => HandleSource::Rule(r.clone()),
                (None, None, Some(g)) if solvers::generate::generated_handles(g).is_some() => {
                    HandleSource::Generated(g.clone())
                }
                _ => HandleSource::None,
            };
            out.push(Dataset { name: e.name.clone(), source, expected: (e.vertices, e.faces), handles });
        }
        if missing_corpus {
            notices.push(format!(
                "the shared corpus is missing here: `mapbench corpus fetch --to DIR` installs it (each mesh from its \
                 pinned public source, checked), then {MESHES_ENV}=DIR"
            ));
        }
    }
    let inline = resolve_inline(cfg, &out)?;
    out.extend(inline);
    let c = &cfg.config;
    crate::names::check_run_names(out.iter().map(|d| d.name.as_str()), &c.energy_names(), &c.solvers)
        .with_context(|| format!("{}: invalid config", cfg.path.display()))?;
    if out.is_empty() {
        // Say why, instead of the plan's "--only selects no run" when no --only was given.
        bail!(
            "{}: no dataset to run: every selected dataset was skipped ({})",
            cfg.path.display(),
            notices.iter().map(|n| n.trim_start_matches("skipping ")).collect::<Vec<_>>().join("; ")
        );
    }
    Ok((out, notices))
}

/// The config's inline `[[dataset]]` entries, which follow the registry's `selected` ones (a
/// name may not be in both). Paths resolve against the config's folder; nothing is read from
/// disk (the fuzz target of the config reader plans runs with it).
pub fn resolve_inline(cfg: &LoadedConfig, selected: &[Dataset]) -> Result<Vec<Dataset>> {
    let mut out = Vec::new();
    for d in &cfg.config.dataset {
        if selected.iter().any(|o: &Dataset| o.name == d.name) {
            bail!("dataset '{}' is both selected from the registry and given inline", d.name);
        }
        let handles = match (&d.handles, &d.handles_rule) {
            (Some(h), _) => HandleSource::File { path: cfg.dir.join(h), set: d.handles_set.unwrap_or(0) },
            (None, Some(r)) => HandleSource::Rule(r.clone()),
            (None, None) => HandleSource::None,
        };
        out.push(Dataset {
            name: d.name.clone(),
            source: MeshSource::File(cfg.dir.join(&d.path)),
            expected: (None, None),
            handles,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reg() -> Registry {
        toml::from_str(
            r#"
            [[dataset]]
            name = "a"
            generator = "bumpy_1k"
            tags = ["small", "generated"]
            [[dataset]]
            name = "b"
            file = "b.obj"
            tags = ["small"]
            [[dataset]]
            name = "c"
            generator = "cap_2k"
            "#,
        )
        .unwrap()
    }

    /// The configs we ship parse, pass the config checks and name only known datasets.
    #[test]
    fn every_shipped_config_loads_and_resolves() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let cfg =
                    crate::plan::config::LoadedConfig::load(&p).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()));
                match resolve(&cfg) {
                    Ok(_) => {}
                    // A config of shared meshes only has nothing to run without the corpus.
                    Err(e) if std::env::var_os(MESHES_ENV).is_none() && format!("{e:#}").contains("was skipped") => {}
                    Err(e) => panic!("{}: {e:#}", p.display()),
                }
                n += 1;
            }
        }
        assert!(n >= 9, "{n} configs in {}", dir.display());
    }

    #[test]
    fn unsafe_entry_names_and_escaping_files_are_refused_naming_the_registry() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("datasets.toml");
        let load = |body: &str| {
            std::fs::write(&path, body).unwrap();
            Registry::load(&path).map(|_| ()).map_err(|e| format!("{e:#}"))
        };
        assert_eq!(load("[[dataset]]\nname = \"ok\"\nfile = \"sub/ok.obj\"\nhandles = \"./ok.p2p.json\"\n"), Ok(()));
        for (body, why) in [
            ("name = \"../x\"\ngenerator = \"bumpy_1k\"", "dataset name \"../x\" contains a path separator"),
            ("name = \"a\\nb\"\ngenerator = \"bumpy_1k\"", "U+000A"),
            ("name = \"\"\ngenerator = \"bumpy_1k\"", "is empty"),
            ("name = \"f\"\nfile = \"../../etc/x.obj\"", "file = \"../../etc/x.obj\" must be a relative path"),
            ("name = \"f\"\nfile = \"/etc/x.obj\"", "must be a relative path"),
            ("name = \"f\"\nfile = \"f.obj\"\nhandles = \"../h.json\"", "handles = \"../h.json\""),
        ] {
            let e = load(&format!("[[dataset]]\n{body}\n")).unwrap_err();
            assert!(e.contains("datasets.toml: invalid registry") && e.contains(why), "{body}: {e}");
        }
    }

    #[test]
    fn selection_by_name_and_tag_without_repeats() {
        let r = reg();
        let names = |s: &[&str]| {
            r.select(&s.iter().map(|x| x.to_string()).collect::<Vec<_>>())
                .unwrap()
                .iter()
                .map(|e| e.name.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(&["c", "tag:small"]), ["c", "a", "b"]);
        assert_eq!(names(&["tag:generated", "a"]), ["a"]);
        assert!(r.select(&["zzz".into()]).unwrap_err().to_string().contains("unknown dataset 'zzz'"));
        assert!(r.select(&["tag:none".into()]).unwrap_err().to_string().contains("tag 'none'"));
    }

    #[test]
    fn prepared_entries_carry_counts_that_are_checked() {
        let r: Registry = toml::from_str(
            "[[dataset]]\nname = \"p\"\ngenerator = \"cap_2k\"\nsha256 = \"ab\"\nvertices = 1850\nfaces = 3584\n",
        )
        .unwrap();
        let e = &r.dataset[0];
        assert_eq!((e.vertices, e.faces, e.sha256.as_deref()), (Some(1850), Some(3584), Some("ab")));
        let ds = Dataset {
            name: "p".into(),
            source: MeshSource::Generated("cap_2k".into()),
            expected: (Some(1850), Some(3584)),
            handles: HandleSource::None,
        };
        assert!(ds.load().is_ok());
        let wrong = Dataset { expected: (Some(1851), None), ..ds };
        let err = wrong.load().unwrap_err().to_string();
        assert!(err.contains("generated:cap_2k: has 1850 vertices") && err.contains("expects 1851 and any"), "{err}");
    }

    #[test]
    fn the_shipped_registry_is_valid() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets.toml");
        let r = Registry::load(&path).unwrap();
        assert!(r.dataset.iter().any(|e| e.name == "camelhead"));
        // every generated mesh is registered
        for g in solvers::generate::generated_names() {
            assert!(r.dataset.iter().any(|e| e.generator.as_deref() == Some(g)), "{g}");
        }
    }
}
