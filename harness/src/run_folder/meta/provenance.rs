//! One line of provenance for a table made from a batch (`mapbench provenance`): when, which
//! revision, which config with which options, on what machine and at what calibration, all
//! read from the batch's `meta.json`, so a Results page never copies them by hand.

use super::Meta;
use crate::utc::utc_date;
use std::path::Path;

impl Meta {
    /// The batch's provenance as one Markdown line. A config under `base` (the repository a
    /// page lives in) is named relative to it; what `meta.json` does not hold reads "not
    /// recorded".
    pub fn provenance_line(&self, base: &Path) -> String {
        let date = self.started_unix.map_or_else(|| "date not recorded".to_string(), utc_date);
        let revision = match (self.git_revision.as_deref(), self.git_dirty) {
            (Some(r), Some(true)) => format!("revision {} with uncommitted changes", short(r)),
            (Some(r), _) => format!("revision {}", short(r)),
            (None, _) => "revision not recorded".to_string(),
        };
        let mut command =
            self.config_path.as_deref().map_or_else(|| "config not recorded".into(), |c| relative(c, base));
        for glob in self.only.iter().flatten() {
            command += &format!(" --only '{glob}'");
        }
        if let Some(shard) = &self.shard {
            command += &format!(" --shard {shard}");
        }
        let mut how = Vec::new();
        if let Some(r) = self.repeat {
            how.push(format!("repeat {r}"));
        }
        let runs = self.plan.as_ref().map(Vec::len);
        let wall = self.started_unix.zip(self.ended_unix).map(|(s, e)| duration(e.saturating_sub(s)));
        how.push(match (runs, wall) {
            (Some(n), Some(w)) => format!("{n} runs in {w}"),
            (Some(n), None) => format!("{n} runs, wall time not recorded"),
            (None, Some(w)) => format!("{w} wall"),
            (None, None) => "wall time not recorded".into(),
        });
        if let Some(j) = self.jobs {
            how.push(format!("--jobs {j}"));
        }
        let machine = match &self.hardware {
            Some(h) => {
                let mut m = vec![h.cpu_model.clone().unwrap_or_else(|| "unknown CPU".into())];
                m.extend(h.cores.or(self.cores).map(|c| format!("{c} cores")));
                m.extend(h.memory_mb.map(|mb| format!("{mb} MiB")));
                m.join(", ")
            }
            None => self.cores.map_or_else(|| "machine not recorded".into(), |c| format!("{c} cores")),
        };
        let calibration = match (self.calibration_median_s, self.calibration_spread) {
            (Some(m), Some(s)) => format!("calibration median {m:.3} s (spread {:.0}%)", 100.0 * s),
            (Some(m), None) => format!("calibration median {m:.3} s"),
            _ => "calibration not recorded".into(),
        };
        format!("{date}, {revision}, `{command}`, {}; {machine}; {calibration}", how.join(", "))
    }
}

/// The first 7 characters of a git revision, as `git log --oneline` shows it.
fn short(revision: &str) -> &str {
    revision.get(..7).unwrap_or(revision)
}

/// `path` relative to `base` when it lies under it.
fn relative(path: &str, base: &Path) -> String {
    let p = Path::new(path);
    let base = base.canonicalize().unwrap_or_else(|_| base.to_path_buf());
    p.strip_prefix(&base).map_or_else(|_| path.to_string(), |r| r.display().to_string())
}

/// Seconds as `9 min 32 s` (or `42 s`, `1 h 3 min`).
fn duration(secs: u64) -> String {
    match secs {
        s if s < 60 => format!("{s} s"),
        s if s < 3600 => format!("{} min {} s", s / 60, s % 60),
        s => format!("{} h {} min", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hardware::Hardware;

    #[test]
    fn a_batch_in_one_line_from_its_meta() {
        let meta = Meta {
            started_unix: Some(1_796_488_097),
            ended_unix: Some(1_796_488_097 + 572),
            git_revision: Some("856182c01e3eadd525666d017e2056950626914c".into()),
            git_dirty: Some(false),
            config_path: Some("/repo/configs/param.toml".into()),
            only: Some(vec!["*__exp-sd__*".into()]),
            repeat: Some(3),
            plan: Some(vec!["a".into(); 170]),
            jobs: Some(2),
            hardware: Some(Hardware {
                cpu_model: Some("Intel(R) Xeon(R) Processor @ 2.80GHz".into()),
                cores: Some(2),
                memory_mb: Some(24105),
                ..Hardware::default()
            }),
            calibration_median_s: Some(0.38677),
            calibration_spread: Some(0.2349),
            ..Meta::default()
        };
        assert_eq!(
            meta.provenance_line(Path::new("/repo")),
            "2026-12-05, revision 856182c, `configs/param.toml --only '*__exp-sd__*'`, repeat 3, 170 runs in 9 min 32 \
             s, --jobs 2; Intel(R) Xeon(R) Processor @ 2.80GHz, 2 cores, 24105 MiB; calibration median 0.387 s \
             (spread 23%)"
        );
        let dirty = Meta { git_dirty: Some(true), ..meta.clone() };
        assert!(dirty
            .provenance_line(Path::new("/elsewhere"))
            .contains("revision 856182c with uncommitted changes, `/repo/configs/param.toml --only '*__exp-sd__*'`"));
    }

    #[test]
    fn what_a_meta_does_not_hold_reads_not_recorded() {
        assert_eq!(
            Meta::default().provenance_line(Path::new("/")),
            "date not recorded, revision not recorded, `config not recorded`, wall time not recorded; machine not \
             recorded; calibration not recorded"
        );
        assert_eq!(duration(59), "59 s");
        assert_eq!(duration(3600 + 180 + 5), "1 h 3 min");
    }
}
