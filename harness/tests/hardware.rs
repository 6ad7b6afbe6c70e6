//! Hardware fingerprints end to end: a batch records its machine in `meta.json`, `merge`
//! keeps each shard's, and the report warns when the shards ran on different machines.

use crate::common;

use common::{mapbench, text, write_config};
use serde_json::Value;
use std::path::Path;

fn meta(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap()
}

#[test]
fn shards_keep_their_machines_and_the_report_says_when_they_differ() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"hw\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n",
    );
    let shard = |i: usize| {
        let out = tmp.path().join(format!("s{i}"));
        let o = mapbench(
            &[
                "run",
                cfg.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--shard",
                &format!("{i}/2"),
                "--no-history",
            ],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        out
    };
    let (s1, s2) = (shard(1), shard(2));
    let hw = meta(&s1)["hardware"].clone();
    assert!(hw["cores"].as_u64().is_some_and(|c| c > 0), "{hw}");
    #[cfg(target_os = "linux")]
    assert!(hw["cpu_model"].is_string() && hw["memory_mb"].is_u64(), "{hw}");
    let merge = |name: &str| {
        let out = tmp.path().join(name);
        let o = mapbench(
            &["merge", s1.to_str().unwrap(), s2.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        (meta(&out), std::fs::read_to_string(out.join("index.html")).unwrap())
    };
    // One machine: the batch's fingerprint, no warning.
    let (m, page) = merge("same");
    assert_eq!(m["hardware"], hw);
    assert!(!page.contains("id=\"hardware\""));
    // Shard 2 on another machine (its meta.json as that machine would have written it).
    let mut other = meta(&s2);
    other["hardware"]["cpu_model"] = "Some Other CPU".into();
    other["hardware"]["isa"] = serde_json::json!(["avx", "avx2", "fma", "avx512f"]);
    std::fs::write(s2.join("meta.json"), other.to_string()).unwrap();
    let (m, page) = merge("mixed");
    assert!(m.get("hardware").is_none(), "no one machine for the batch: {m}");
    let shards = m["merged_from"].as_array().unwrap();
    assert_eq!(shards[0]["hardware"], hw);
    assert_eq!(shards[1]["hardware"]["cpu_model"], "Some Other CPU");
    assert!(page.contains("<b>The shards ran on 2 different machines:</b>"), "{page}");
    assert!(page.contains("Some Other CPU (") && page.contains("ran shard 2/2"), "{page}");
    assert!(page.contains("time_norm (each shard's times over its own machine calibration)"));
}
