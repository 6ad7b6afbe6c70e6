//! Which settings and provenance of two batches' `meta.json` differ.

use crate::run_folder::meta::Meta;
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;

/// A setting in which the two batches differ.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingDiff {
    pub setting: String,
    pub a: String,
    pub b: String,
}

/// The `meta.json` keys of how a batch ran that change results or times, with their values
/// (`None`: no value); the rest of `meta.json` is provenance or derived (`plan` is the list
/// of runs, `stop_per_energy` repeats `settings_per_energy`).
fn run_keys(m: &Meta) -> [(&'static str, Option<Value>); 7] {
    [
        ("repeat", json(&m.repeat)),
        ("jobs", json(&m.jobs)),
        ("threads_per_run", json(&m.threads_per_run)),
        ("linear_ordering", json(&m.linear_ordering)),
        ("only", json(&m.only)),
        ("shard", json(&m.shard)),
        ("meshes_dir", json(&m.meshes_dir)),
    ]
}

/// A field as JSON, so that every value prints the way `meta.json` holds it.
fn json<T: Serialize>(v: &Option<T>) -> Option<Value> {
    v.as_ref().and_then(|v| serde_json::to_value(v).ok())
}

/// What differs between two `meta.json`: the keys of `run_keys`, the config as written
/// (`config.*`, `(unset)` where a side leaves a key to its default) and the settings each
/// energy resolved to (`settings[energies].*`, one line for the energies that differ alike).
pub fn settings_diff(a: &Meta, b: &Meta) -> Vec<SettingDiff> {
    let mut out = Vec::new();
    let mut diff = |setting: String, va: Option<&String>, vb: Option<&String>| {
        if va != vb {
            let show = |v: Option<&String>| v.cloned().unwrap_or_else(|| "(unset)".into());
            out.push(SettingDiff { setting, a: show(va), b: show(vb) });
        }
    };
    for ((k, va), (_, vb)) in run_keys(a).into_iter().zip(run_keys(b)) {
        let (fa, fb) = (flat(va.as_ref(), k), flat(vb.as_ref(), k));
        for s in union(&fa, &fb) {
            diff(s.clone(), fa.get(&s), fb.get(&s));
        }
    }
    let config = |m: &Meta| (!m.config.is_null()).then(|| m.config.clone());
    let (ca, cb) = (flat(config(a).as_ref(), "config"), flat(config(b).as_ref(), "config"));
    for s in union(&ca, &cb) {
        diff(s.clone(), ca.get(&s), cb.get(&s));
    }
    // Per energy, grouped: (setting, A, B) -> the energies where it differs so.
    let per_energy = |m: &Meta| m.settings_per_energy.clone().unwrap_or_default();
    let (ea, eb) = (per_energy(a), per_energy(b));
    let mut grouped: BTreeMap<(String, Option<String>, Option<String>), Vec<String>> = BTreeMap::new();
    let energies: std::collections::BTreeSet<&String> = ea.keys().chain(eb.keys()).collect();
    for e in energies {
        match (ea.get(e), eb.get(e)) {
            (Some(sa), Some(sb)) => {
                let (fa, fb) = (flat(Some(sa), ""), flat(Some(sb), ""));
                for s in union(&fa, &fb) {
                    let (va, vb) = (fa.get(&s).cloned(), fb.get(&s).cloned());
                    if va != vb {
                        grouped.entry((s, va, vb)).or_default().push(e.clone());
                    }
                }
            }
            (sa, sb) => {
                let present = |v: Option<&Value>| v.map(|_| "(in the batch)".to_string());
                diff(format!("settings[{e}]"), present(sa).as_ref(), present(sb).as_ref());
            }
        }
    }
    for ((s, va, vb), es) in grouped {
        diff(format!("settings[{}].{s}", es.join(", ")), va.as_ref(), vb.as_ref());
    }
    out
}

/// A JSON value as `path -> leaf` (objects descended, arrays and scalars as their JSON, strings
/// bare); a missing value gives no entry.
fn flat(v: Option<&Value>, prefix: &str) -> BTreeMap<String, String> {
    fn walk(path: String, v: &Value, out: &mut BTreeMap<String, String>) {
        match v {
            Value::Object(m) if !m.is_empty() => {
                for (k, x) in m {
                    walk(if path.is_empty() { k.clone() } else { format!("{path}.{k}") }, x, out);
                }
            }
            Value::String(s) => {
                out.insert(path, s.clone());
            }
            other => {
                out.insert(path, other.to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    if let Some(v) = v {
        walk(prefix.to_string(), v, &mut out);
    }
    out
}

fn union(a: &BTreeMap<String, String>, b: &BTreeMap<String, String>) -> Vec<String> {
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    keys.into_iter().cloned().collect()
}

/// Where and how each batch ran, from `meta.json`: the lines either side has.
pub(super) fn provenance(a: Option<&Meta>, b: Option<&Meta>) -> Vec<(String, String, String)> {
    let revision = |m: Option<&Meta>| {
        let m = m?;
        let rev = m.git_revision.as_ref()?;
        let dirty = m.git_dirty == Some(true);
        // By characters: a hand-edited meta.json need not be ASCII.
        let short: String = rev.chars().take(12).collect();
        Some(format!("{short}{}", if dirty { " (dirty)" } else { "" }))
    };
    let shown = |v: Option<Value>| match v? {
        Value::Null => None,
        Value::String(s) => Some(s),
        v => Some(v.to_string()),
    };
    let fields = |m: Option<&Meta>| {
        let Some(m) = m else { return [(); 9].map(|_| None) };
        [
            json(&m.host),
            json(&m.cores),
            json(&m.mapbench_version),
            json(&m.rustc),
            json(&m.started_unix),
            json(&m.calibration_median_s),
            json(&m.calibration_spread),
            json(&m.interrupted),
            json(&m.resume),
        ]
        .map(shown)
    };
    let mut out = Vec::new();
    let mut line = |what: &str, va: Option<String>, vb: Option<String>| {
        if va.is_some() || vb.is_some() {
            let show = |v: Option<String>| v.unwrap_or_else(|| "-".into());
            out.push((what.to_string(), show(va), show(vb)));
        }
    };
    line("git revision", revision(a), revision(b));
    let keys = [
        "host",
        "cores",
        "mapbench_version",
        "rustc",
        "started_unix",
        "calibration_median_s",
        "calibration_spread",
        "interrupted",
        "resume",
    ];
    for ((k, va), vb) in keys.into_iter().zip(fields(a)).zip(fields(b)) {
        line(k, va, vb);
    }
    out
}
