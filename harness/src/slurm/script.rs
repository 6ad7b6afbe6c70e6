//! The job scripts `submit` writes: one array job (a task per shard) and one merge job. They
//! are plain bash with every path absolute, so they can be read, and submitted again by hand.
//!
//! A shard's task runs `mapbench run` in the background and waits for it: Slurm sends SIGTERM
//! to every process of the job (on `scancel` and at the time limit), `mapbench` stops cleanly
//! on it and a second one would make it exit at once, so the script only catches the signal
//! and goes on waiting. Exit 1 of `run` (the shard ran to its end and some runs failed, which
//! the report shows) ends the task successfully, so the merge, which waits for every task to
//! succeed, still runs; each task's and the merge's own exit code is kept in a file beside
//! the scripts.

use crate::history::HistoryChoice;
use std::path::{Path, PathBuf};

/// What the job scripts run, all paths absolute.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Commands {
    pub mapbench: PathBuf,
    pub config: PathBuf,
    /// The submission's folder (the merged run folder; `slurm/` inside it).
    pub out: PathBuf,
    /// The folder the jobs run in (the submitter's working directory: relative paths of the
    /// config's defaults, as `reports/history.sqlite`, resolve as they did at `submit`).
    pub workdir: PathBuf,
    pub shards: usize,
    pub only: Vec<String>,
    pub repeat: Option<usize>,
    /// Cores of each task: `--cpus-per-task` and the shard's `run --jobs`.
    pub cpus_per_task: usize,
    /// `--history PATH` or `--no-history`, given to each shard and to the merge.
    pub history: HistoryChoice,
    /// `MAPBENCH_MESHES` at `submit`, set in the jobs so they resolve the same datasets.
    pub meshes: Option<PathBuf>,
}

/// The folder `submit` keeps its files in, inside the submission's folder.
pub fn slurm_dir(out: &Path) -> PathBuf {
    out.join(crate::run_folder::SUBMISSION_DIR)
}

/// Shard `index` of `count`'s run folder.
pub fn shard_dir(out: &Path, index: usize, count: usize) -> PathBuf {
    slurm_dir(out).join(format!("shard-{index}-of-{count}"))
}

/// Where a shard's task leaves its exit code.
pub fn shard_exit(out: &Path, index: usize) -> PathBuf {
    slurm_dir(out).join(format!("shard-{index}.exit"))
}

/// Where the merge job leaves its exit code.
pub fn merge_exit(out: &Path) -> PathBuf {
    slurm_dir(out).join("merge.exit")
}

pub fn shards_json(out: &Path) -> PathBuf {
    slurm_dir(out).join("shards.json")
}

pub fn logs_dir(out: &Path) -> PathBuf {
    slurm_dir(out).join("logs")
}

/// A word for bash: in single quotes, each `'` closed, escaped and reopened.
pub fn quote(word: &str) -> String {
    format!("'{}'", word.replace('\'', r"'\''"))
}

fn quote_path(p: &Path) -> String {
    quote(&p.display().to_string())
}

impl Commands {
    fn preamble(&self, what: &str) -> String {
        let mut s = format!(
            "#!/bin/bash\n# Written by `mapbench submit`: {what} of config {}.\nset -u\ncd {} || exit 2\n",
            self.config.display(),
            quote_path(&self.workdir)
        );
        if let Some(m) = &self.meshes {
            s += &format!("export {}={}\n", crate::plan::registry::MESHES_ENV, quote_path(m));
        }
        s
    }

    /// `--history PATH` / `--no-history` as words.
    fn history_words(&self) -> String {
        match &self.history {
            HistoryChoice::FromConfig => String::new(),
            HistoryChoice::Path(p) => format!(" --history {}", quote_path(p)),
            HistoryChoice::Off => " --no-history".into(),
        }
    }

    /// The array job: task `$SLURM_ARRAY_TASK_ID` runs its shard of `shards.json`.
    pub fn array_script(&self) -> String {
        let n = self.shards;
        let mut run = format!(
            "{} run {} --shard-plan {} --shard \"$i/{n}\" --out {}\"/shard-$i-of-{n}\" --resume --jobs {}",
            quote_path(&self.mapbench),
            quote_path(&self.config),
            quote_path(&shards_json(&self.out)),
            quote_path(&slurm_dir(&self.out)),
            self.cpus_per_task
        );
        for g in &self.only {
            run += &format!(" --only {}", quote(g));
        }
        if let Some(r) = self.repeat {
            run += &format!(" --repeat {r}");
        }
        run += &self.history_words();
        format!(
            "{}i=${{SLURM_ARRAY_TASK_ID:?not an array task}}\n\
             # SIGTERM reaches mapbench from Slurm itself; here it only ends a `wait` early.\n\
             trap 'true' TERM INT\n\
             {run} &\n\
             pid=$!\n\
             wait \"$pid\"; code=$?\n\
             while kill -0 \"$pid\" 2>/dev/null; do wait \"$pid\"; code=$?; done\n\
             # mapbench's own status (bash keeps it), also when it ended between the two waits\n\
             wait \"$pid\"; code=$?\n\
             echo \"$code\" > {}\"/shard-$i.exit\"\n\
             # 1: the shard ran to its end and some runs failed (the report shows them).\n\
             if [ \"$code\" = 1 ]; then exit 0; fi\n\
             exit \"$code\"\n",
            self.preamble(&format!("shard $SLURM_ARRAY_TASK_ID of {n}")),
            quote_path(&slurm_dir(&self.out)),
        )
    }

    /// The merge job: every shard's folder into the submission's folder, the batch appended to
    /// the history once.
    pub fn merge_script(&self) -> String {
        let shards: String = (1..=self.shards)
            .map(|i| format!(" \\\n  {}", quote_path(&shard_dir(&self.out, i, self.shards))))
            .collect();
        format!(
            "{}{} merge{shards} \\\n  --out {}{}\ncode=$?\necho \"$code\" > {}\nexit \"$code\"\n",
            self.preamble("the merge of the shards"),
            quote_path(&self.mapbench),
            quote_path(&self.out),
            self.history_words(),
            quote_path(&merge_exit(&self.out)),
        )
    }

    /// The job that computes the reference minima no store holds yet, once, before the shards
    /// (which would otherwise each compute the ones of their own runs).
    pub fn references_script(&self) -> String {
        let mut cmd = format!("{} references {}", quote_path(&self.mapbench), quote_path(&self.config));
        for g in &self.only {
            cmd += &format!(" --only {}", quote(g));
        }
        format!("{}{cmd}\n", self.preamble("the reference minima"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn commands() -> Commands {
        Commands {
            mapbench: "/opt/mapbench/bin/mapbench".into(),
            config: "/home/a/configs/ci.toml".into(),
            out: "/scratch/it's here".into(),
            workdir: "/home/a".into(),
            shards: 3,
            only: vec!["*__sd__*".into()],
            repeat: Some(2),
            cpus_per_task: 4,
            history: HistoryChoice::Path("/h/db.sqlite".into()),
            meshes: Some("/data/meshes".into()),
        }
    }

    #[test]
    fn quoting_keeps_any_word_one_word() {
        assert_eq!(quote("plain"), "'plain'");
        assert_eq!(quote("it's $HOME"), r"'it'\''s $HOME'");
        let out = std::process::Command::new("bash")
            .arg("-c")
            .arg(format!("printf '%s|' {} {}", quote("a b"), quote("it's $HOME `x`")))
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&out.stdout), "a b|it's $HOME `x`|");
    }

    #[test]
    fn the_scripts_run_their_shard_and_the_merge_with_every_option() {
        let c = commands();
        let a = c.array_script();
        assert!(a.starts_with("#!/bin/bash\n"), "{a}");
        assert!(a.contains("cd '/home/a' || exit 2\nexport MAPBENCH_MESHES='/data/meshes'\n"), "{a}");
        assert!(
            a.contains(
                "'/opt/mapbench/bin/mapbench' run '/home/a/configs/ci.toml' --shard-plan '/scratch/it'\\''s \
                 here/slurm/shards.json' --shard \"$i/3\" --out '/scratch/it'\\''s here/slurm'\"/shard-$i-of-3\" \
                 --resume --jobs 4 --only '*__sd__*' --repeat 2 --history '/h/db.sqlite' &"
            ),
            "{a}"
        );
        assert!(a.contains("if [ \"$code\" = 1 ]; then exit 0; fi"), "{a}");
        let m = c.merge_script();
        assert!(m.contains("merge \\\n  '/scratch/it'\\''s here/slurm/shard-1-of-3' \\\n"), "{m}");
        assert!(m.contains("--out '/scratch/it'\\''s here' --history '/h/db.sqlite'\ncode=$?"), "{m}");
        assert!(m.contains("echo \"$code\" > '/scratch/it'\\''s here/slurm/merge.exit'"), "{m}");
        let r = c.references_script();
        assert!(r.ends_with("'/opt/mapbench/bin/mapbench' references '/home/a/configs/ci.toml' --only '*__sd__*'\n"));
    }

    /// The array script, run by bash as Slurm would (without Slurm): the exit code files and
    /// the task's code, a failed run's 1 turned into success, a signal waited out.
    #[test]
    fn the_array_task_keeps_the_exit_code_and_waits_out_a_signal() {
        let dir = tempfile::tempdir().unwrap();
        let fake = dir.path().join("fake-mapbench");
        // exits with the code in $FAKE_CODE after $FAKE_SLEEP seconds, also when TERMed
        std::fs::write(
            &fake,
            "#!/bin/bash\ntrap 'echo term >> \"$FAKE_LOG\"' TERM\nsleep \"$FAKE_SLEEP\" & wait $!\n\
             sleep 0.2\nexit \"$FAKE_CODE\"\n",
        )
        .unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
        let mut c = commands();
        c.mapbench = fake;
        c.out = dir.path().join("out");
        c.workdir = dir.path().to_path_buf();
        std::fs::create_dir_all(slurm_dir(&c.out)).unwrap();
        let script = dir.path().join("array.sh");
        std::fs::write(&script, c.array_script()).unwrap();
        let run = |code: &str, sleep: &str, term: bool| {
            let mut child = std::process::Command::new("bash")
                .arg(&script)
                .env("SLURM_ARRAY_TASK_ID", "2")
                .env("FAKE_CODE", code)
                .env("FAKE_SLEEP", sleep)
                .env("FAKE_LOG", dir.path().join("log"))
                .spawn()
                .unwrap();
            if term {
                std::thread::sleep(std::time::Duration::from_millis(300));
                // as Slurm: every process of the job (the script's child, then the script)
                let parent = child.id().to_string();
                std::process::Command::new("pkill").args(["-TERM", "-P", &parent]).status().unwrap();
                let _ = nix::sys::signal::kill(
                    nix::unistd::Pid::from_raw(child.id() as i32),
                    nix::sys::signal::Signal::SIGTERM,
                );
            }
            let status = child.wait().unwrap();
            let kept = std::fs::read_to_string(shard_exit(&c.out, 2)).unwrap();
            (status.code(), kept.trim().to_string())
        };
        assert_eq!(run("0", "0", false), (Some(0), "0".into()));
        assert_eq!(run("1", "0", false), (Some(0), "1".into()));
        assert_eq!(run("2", "0", false), (Some(2), "2".into()));
        // the script outlives the signal and reports mapbench's own code
        assert_eq!(run("143", "2", true), (Some(143), "143".into()));
        assert_eq!(std::fs::read_to_string(dir.path().join("log")).unwrap().trim(), "term");
    }
}
