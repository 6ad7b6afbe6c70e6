//! Handles (positional constraints) of `deform` datasets: from a `*.p2p.json` file in the
//! shared corpus format, from a generated shape's rule, or from a named rule.

use anyhow::{bail, Context, Result};
use solvers::generate::generated_handles;
use solvers::mesh::Handle;
use solvers::mesh::Mesh;
use solvers::tasks::deform::rule_handles;
use std::path::{Path, PathBuf};

/// Where a dataset's handles come from.
#[derive(Clone, Debug, PartialEq)]
pub enum HandleSource {
    None,
    /// The rule of a generated shape (`solvers::generate::generated_handles`).
    Generated(String),
    /// A `*.p2p.json` file and the index of its constraint set.
    File {
        path: PathBuf,
        set: usize,
    },
    /// A rule of `solvers::tasks::deform::HANDLE_RULES`.
    Rule(String),
}

impl HandleSource {
    /// The handles for `mesh`; errors name the file.
    pub fn load(&self, mesh: &Mesh) -> Result<Vec<Handle>> {
        let handles = match self {
            HandleSource::None => {
                bail!("{}: no handles (give `handles = \"FILE\"` or `handles_rule` in the dataset entry)", mesh.source)
            }
            HandleSource::Generated(g) => {
                generated_handles(g).with_context(|| format!("generated mesh '{g}' has no handles"))
            }
            HandleSource::File { path, set } => read_p2p(path, *set),
            HandleSource::Rule(r) => rule_handles(mesh, r).map_err(anyhow::Error::msg),
        }?;
        check_conflicts(&handles).with_context(|| format!("{}: handles of {}", self.origin(), mesh.source))?;
        Ok(handles)
    }

    /// Where the handles come from, for messages.
    fn origin(&self) -> String {
        match self {
            HandleSource::None => "no handles".into(),
            HandleSource::Generated(g) => format!("generated:{g}"),
            HandleSource::File { path, set } => format!("{} (set {set})", path.display()),
            HandleSource::Rule(r) => format!("handles_rule '{r}'"),
        }
    }
}

/// `handles` and `handles_rule` exclude each other; `handles_set` needs `handles`.
pub fn check_handles(file: bool, set: Option<usize>, rule: Option<&str>) -> Result<()> {
    if file && rule.is_some() {
        bail!("give 'handles' or 'handles_rule', not both");
    }
    if set.is_some() && !file {
        bail!("'handles_set' needs 'handles'");
    }
    if let Some(r) = rule {
        if !solvers::tasks::deform::HANDLE_RULES.contains(&r) {
            bail!("unknown handles_rule '{r}' (known: {})", solvers::tasks::deform::HANDLE_RULES.join(", "));
        }
    }
    Ok(())
}

/// One vertex pulled to two different targets has no meaning as a constraint (the penalty
/// would settle between them): refuse it. A repeated identical handle is harmless.
pub fn check_conflicts(handles: &[Handle]) -> Result<()> {
    let mut first: std::collections::HashMap<usize, (usize, [f64; 2])> = Default::default();
    for (i, h) in handles.iter().enumerate() {
        match first.get(&h.vertex) {
            Some(&(j, t)) if t != h.target => bail!(
                "handle {i} pulls vertex {} to {:?}, but handle {j} pulls it to {:?}: conflicting handles",
                h.vertex,
                h.target,
                t
            ),
            Some(_) => {}
            None => {
                first.insert(h.vertex, (i, h.target));
            }
        }
    }
    Ok(())
}

/// A `*.p2p.json` file of the shared corpus: `p2p_sets[set]` with `src_vertex` (vertex
/// indices, base `vertex_index_base`, default 0) and `dst` (targets in the mesh's frame).
pub fn read_p2p(path: &Path, set: usize) -> Result<Vec<Handle>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read handles", path.display()))?;
    parse_p2p(&text, path, set)
}

/// The handles of constraint set `set` of a `*.p2p.json` text; `path` names it in errors.
pub fn parse_p2p(text: &str, path: &Path, set: usize) -> Result<Vec<Handle>> {
    let json: serde_json::Value =
        serde_json::from_str(text).with_context(|| format!("{}: invalid JSON", path.display()))?;
    let base = json.get("vertex_index_base").and_then(|b| b.as_u64()).unwrap_or(0) as usize;
    let sets = json
        .get("p2p_sets")
        .and_then(|s| s.as_array())
        .with_context(|| format!("{}: no 'p2p_sets' array", path.display()))?;
    let s = sets
        .get(set)
        .with_context(|| format!("{}: handles_set = {set}, but the file has {} sets", path.display(), sets.len()))?;
    let field = |name: &str| {
        s.get(name).and_then(|v| v.as_array()).with_context(|| format!("{}: set {set} has no '{name}'", path.display()))
    };
    let (verts, dst) = (field("src_vertex")?, field("dst")?);
    if verts.len() != dst.len() {
        bail!("{}: set {set} has {} src_vertex but {} dst entries", path.display(), verts.len(), dst.len());
    }
    verts
        .iter()
        .zip(dst)
        .enumerate()
        .map(|(i, (v, d))| {
            let vertex = v
                .as_u64()
                .and_then(|v| (v as usize).checked_sub(base))
                .with_context(|| format!("{}: set {set} handle {i}: bad vertex index {v}", path.display()))?;
            let xy: Option<Vec<f64>> = d.as_array().map(|a| a.iter().filter_map(|c| c.as_f64()).collect());
            match xy.as_deref() {
                Some([x, y]) => Ok(Handle { vertex, target: [*x, *y] }),
                _ => bail!("{}: set {set} handle {i}: dst {d} is not [x, y]", path.display()),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p2p_files_are_read_and_bad_ones_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.p2p.json");
        std::fs::write(
            &p,
            r#"{"vertex_index_base": 0, "p2p_sets": [
                {"src_vertex": [3, 5], "dst": [[1.0, 2.0], [-0.5, 0.25]]},
                {"src_vertex": [1], "dst": [[0.0]]}]}"#,
        )
        .unwrap();
        let h = read_p2p(&p, 0).unwrap();
        assert_eq!(h, [Handle { vertex: 3, target: [1.0, 2.0] }, Handle { vertex: 5, target: [-0.5, 0.25] }]);
        let err = |set| format!("{:#}", read_p2p(&p, set).unwrap_err());
        assert!(err(1).contains("dst [0.0] is not [x, y]"), "{}", err(1));
        assert!(err(2).contains("handles_set = 2, but the file has 2 sets"));
        std::fs::write(&p, "{").unwrap();
        assert!(err(0).contains("h.p2p.json: invalid JSON"));
    }

    #[test]
    fn the_shared_handle_files_load_when_present() {
        let Ok(dir) = std::env::var("MAPBENCH_MESHES") else { return };
        for (name, sets) in [("archer", 2), ("rex", 2), ("raptor", 4)] {
            let mesh = solvers::mesh::load_obj(&Path::new(&dir).join(format!("{name}.obj"))).unwrap();
            for set in 0..sets {
                let h = read_p2p(&Path::new(&dir).join(format!("{name}.p2p.json")), set).unwrap();
                assert!(!h.is_empty() && h.iter().all(|h| h.vertex < mesh.n_vertices()), "{name} {set}");
            }
        }
    }
}
