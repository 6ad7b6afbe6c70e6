//! Which final maps a run folder keeps (`maps` in the config). Every map is a run's exact
//! result, but a nightly of 288 runs at 16 bytes per vertex and map would be most of the
//! folder; by default one map per (dataset, energy) is kept, the one the report shows.

use super::map::{legacy_obj_path, mesh_path, uv_path};
use super::meta::Meta;
use super::{run_stem, Status, SummaryRow};
use std::path::Path;

pub use super::maps_policy::Maps;

impl Maps {
    /// The policy a run folder was written with (`meta.json`'s `maps`); folders written
    /// before the key kept every map.
    pub fn of_meta(meta: &Meta) -> Maps {
        meta.maps.unwrap_or(Maps::All)
    }
}

/// The run of a (dataset, energy) group whose map `best` keeps: of the finished runs (`ok` or
/// `not_converged`, the runs with a map), converged before not converged, then the lowest
/// final energy, then the first in the plan's order. `None` when no run finished.
pub fn best_of_group(runs: &[&SummaryRow]) -> Option<usize> {
    let rank = |r: &SummaryRow| (r.status != Status::Ok, r.final_energy.filter(|e| e.is_finite()));
    let mut best: Option<usize> = None;
    for (i, r) in runs.iter().enumerate() {
        if !r.status.ran() {
            continue;
        }
        let better = match best {
            None => true,
            Some(b) => {
                let ((c1, e1), (c0, e0)) = (rank(r), rank(runs[b]));
                match (c1.cmp(&c0), e1, e0) {
                    (std::cmp::Ordering::Less, _, _) => true,
                    (std::cmp::Ordering::Greater, _, _) => false,
                    (_, Some(a), Some(b)) => a < b,
                    (_, Some(_), None) => true,
                    _ => false,
                }
            }
        };
        if better {
            best = Some(i);
        }
    }
    best
}

/// For each of `rows`, whether `maps` keeps its map, `also` naming the solvers whose maps
/// `best` keeps besides the best of each group (`maps_keep`).
pub fn kept(maps: Maps, also: &[String], rows: &[SummaryRow]) -> Vec<bool> {
    match maps {
        Maps::All => rows.iter().map(|r| r.status.ran()).collect(),
        Maps::None => vec![false; rows.len()],
        Maps::Best => {
            let finished = |r: &SummaryRow| r.status.ran();
            let mut keep: Vec<bool> = rows.iter().map(|r| finished(r) && also.contains(&r.solver)).collect();
            let mut groups: Vec<(&str, &str)> = Vec::new();
            for r in rows {
                if !groups.contains(&(r.dataset.as_str(), r.energy.as_str())) {
                    groups.push((&r.dataset, &r.energy));
                }
            }
            for (d, e) in groups {
                let members: Vec<usize> =
                    (0..rows.len()).filter(|&i| rows[i].dataset == d && rows[i].energy == e).collect();
                let runs: Vec<&SummaryRow> = members.iter().map(|&i| &rows[i]).collect();
                if let Some(b) = best_of_group(&runs) {
                    keep[members[b]] = true;
                }
            }
            keep
        }
    }
}

/// Remove the maps of `rows` that `maps` does not keep (either format), and the mesh copies
/// of datasets none of whose kept maps is left. Returns the runs whose map is kept but
/// absent (a resumed run of an earlier batch that did not keep it).
pub fn prune(dir: &Path, maps: Maps, also: &[String], rows: &[SummaryRow]) -> Vec<String> {
    let keep = kept(maps, also, rows);
    let mut missing = Vec::new();
    let mut meshes_used: Vec<&str> = Vec::new();
    let mut datasets: Vec<&str> = Vec::new();
    for (r, &k) in rows.iter().zip(&keep) {
        let stem = run_stem(&r.dataset, &r.energy, &r.solver);
        if !datasets.contains(&r.dataset.as_str()) {
            datasets.push(&r.dataset);
        }
        if k {
            if uv_path(dir, &stem).exists() {
                meshes_used.push(&r.dataset);
            } else if !legacy_obj_path(dir, &stem).exists() {
                missing.push(stem);
            }
        } else {
            // Absent files are fine: most runs never had one.
            let _ = std::fs::remove_file(uv_path(dir, &stem));
            let _ = std::fs::remove_file(legacy_obj_path(dir, &stem));
        }
    }
    for d in datasets {
        if !meshes_used.contains(&d) {
            let _ = std::fs::remove_file(mesh_path(dir, d));
        }
    }
    for sub in ["uv", "meshes"] {
        // Only removed when empty (remove_dir refuses otherwise).
        let _ = std::fs::remove_dir(dir.join(sub));
    }
    missing
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(dataset: &str, energy: &str, solver: &str, status: Status, e: Option<f64>) -> SummaryRow {
        SummaryRow {
            dataset: dataset.into(),
            energy: energy.into(),
            solver: solver.into(),
            status,
            final_energy: e,
            ..Default::default()
        }
    }

    #[test]
    fn best_is_converged_first_then_lowest_energy_then_first() {
        use Status::*;
        let rows = [
            row("a", "sd", "newton", Failed, None),
            row("a", "sd", "slim", NotConverged, Some(1.0)),
            row("a", "sd", "kp", Ok, Some(2.5)),
            row("a", "sd", "cm", Ok, Some(2.0)),
            row("a", "sd", "fp4", Ok, Some(2.0)),
            row("a", "sd", "akvf", Skipped, None),
        ];
        let refs: Vec<&SummaryRow> = rows.iter().collect();
        assert_eq!(best_of_group(&refs), Some(3));
        // Nothing converged: the lowest energy of the finished ones.
        let rows2 = [row("a", "sd", "x", NotConverged, Some(3.0)), row("a", "sd", "y", NotConverged, Some(2.0))];
        assert_eq!(best_of_group(&rows2.iter().collect::<Vec<_>>()), Some(1));
        // A NaN energy loses to a number.
        let rows3 = [row("a", "sd", "x", Ok, Some(f64::NAN)), row("a", "sd", "y", Ok, Some(9.0))];
        assert_eq!(best_of_group(&rows3.iter().collect::<Vec<_>>()), Some(1));
        assert_eq!(best_of_group(&[&rows[0], &rows[5]]), None);
    }

    #[test]
    fn kept_per_policy() {
        use Status::*;
        let rows = vec![
            row("a", "sd", "kp", Ok, Some(2.0)),
            row("a", "sd", "cm", Ok, Some(1.5)),
            row("a", "bconf", "kp", Ok, Some(4.0)),
            row("b", "sd", "kp", NotConverged, Some(3.0)),
            row("b", "sd", "cm", Failed, None),
        ];
        assert_eq!(kept(Maps::Best, &[], &rows), [false, true, true, true, false]);
        assert_eq!(kept(Maps::All, &[], &rows), [true, true, true, true, false]);
        assert_eq!(kept(Maps::None, &[], &rows), [false; 5]);
        // maps_keep: kp's maps beside each best (cm's failed run has none to keep).
        let also = ["kp".to_string(), "cm".to_string()];
        assert_eq!(kept(Maps::Best, &also, &rows), [true, true, true, true, false]);
        assert_eq!(kept(Maps::Best, &also[1..], &rows), [false, true, true, true, false]);
    }

    #[test]
    fn the_policy_of_a_folder_comes_from_meta_json() {
        let of = |v: serde_json::Value| Maps::of_meta(&serde_json::from_value(v).unwrap());
        assert_eq!(of(serde_json::json!({"maps": "none"})), Maps::None);
        assert_eq!(of(serde_json::json!({"maps": "best"})), Maps::Best);
        // Before the key: every map was kept.
        assert_eq!(of(serde_json::json!({"config": {}})), Maps::All);
    }

    #[test]
    fn prune_removes_what_is_not_kept_and_unused_meshes() {
        use Status::*;
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let rows = vec![
            row("a", "sd", "kp", Ok, Some(2.0)),
            row("a", "sd", "cm", Ok, Some(1.5)),
            row("b", "sd", "kp", Ok, Some(1.0)),
        ];
        for p in [uv_path(d, "a__sd__kp"), uv_path(d, "a__sd__cm"), legacy_obj_path(d, "b__sd__kp")] {
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, b"x").unwrap();
        }
        for m in ["a", "b"] {
            std::fs::create_dir_all(d.join("meshes")).unwrap();
            std::fs::write(mesh_path(d, m), b"x").unwrap();
        }
        assert!(prune(d, Maps::Best, &[], &rows).is_empty());
        assert!(!uv_path(d, "a__sd__kp").exists() && uv_path(d, "a__sd__cm").exists());
        // b's kept map is a legacy OBJ (self-contained): its mesh copy is not needed.
        assert!(mesh_path(d, "a").exists() && !mesh_path(d, "b").exists());
        assert!(legacy_obj_path(d, "b__sd__kp").exists());
        // none: everything goes, folders too.
        assert!(prune(d, Maps::None, &[], &rows).is_empty());
        assert!(!d.join("uv").exists() && !d.join("meshes").exists());
        // all, with nothing left: every finished run's map is reported missing.
        assert_eq!(prune(d, Maps::All, &[], &rows).len(), 3);
    }
}
