//! Slurm's commands as `submit` uses them: `sbatch --parsable` to submit, `squeue` to see what
//! is still queued or running, `scancel`. Behind a trait so that the submission logic is
//! tested without a cluster; the live cluster test drives the real one.

use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::Command;

/// A job (or an array task) still in the queue.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Queued {
    /// `123` or, for an array task, `123_4`.
    pub id: String,
    /// `PENDING`, `RUNNING`, `COMPLETING`, ...
    pub state: String,
    /// Why it waits (`Dependency`, `DependencyNeverSatisfied`, `Resources`, ...).
    pub reason: String,
}

impl Queued {
    /// A job that waits for jobs which failed: it will never start.
    pub fn never_starts(&self) -> bool {
        self.state == "PENDING" && self.reason.contains("DependencyNeverSatisfied")
    }
}

pub trait Scheduler {
    /// Submit `script` with `args` before it (`--array`, `--dependency`, the user's); the job id.
    fn submit(&self, args: &[String], script: &Path) -> Result<String>;
    /// The jobs among `ids` still queued or running (array tasks one by one).
    fn queued(&self, ids: &[String]) -> Result<Vec<Queued>>;
    fn cancel(&self, id: &str) -> Result<()>;
}

/// The cluster's own commands.
pub struct Slurm;

fn run(cmd: &mut Command, what: &str) -> Result<String> {
    let out = cmd.output().with_context(|| format!("cannot run {what} (is Slurm installed and on PATH?)"))?;
    if !out.status.success() {
        bail!("{what} failed ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

impl Scheduler for Slurm {
    fn submit(&self, args: &[String], script: &Path) -> Result<String> {
        let out = run(Command::new("sbatch").arg("--parsable").args(args).arg(script), "sbatch")?;
        parse_job_id(&out).with_context(|| format!("sbatch {}", script.display()))
    }

    fn queued(&self, ids: &[String]) -> Result<Vec<Queued>> {
        if ids.is_empty() {
            return Ok(Vec::new());
        }
        // Jobs that left the queue are not listed; when none of the ids is known any more,
        // squeue says "Invalid job id", which is an empty queue here.
        let out = Command::new("squeue")
            .args(["-h", "-r", "-o", "%i|%T|%r", "-j", &ids.join(",")])
            .output()
            .context("cannot run squeue (is Slurm installed and on PATH?)")?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            // every id has left the queue (and slurmctld's memory of it)
            if err.contains("Invalid job id") {
                return Ok(Vec::new());
            }
            bail!("squeue failed ({}): {}", out.status, err.trim());
        }
        Ok(parse_queue(&String::from_utf8_lossy(&out.stdout)))
    }

    fn cancel(&self, id: &str) -> Result<()> {
        run(Command::new("scancel").arg(id), "scancel").map(|_| ())
    }
}

/// `sbatch --parsable` prints `<id>` or `<id>;<cluster>`.
pub fn parse_job_id(out: &str) -> Result<String> {
    let id = out.trim().split(';').next().unwrap_or_default().trim();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        bail!("expected a job id from sbatch --parsable, got {:?}", out.trim());
    }
    Ok(id.to_string())
}

/// Lines of `squeue -h -o '%i|%T|%r'`.
pub fn parse_queue(out: &str) -> Vec<Queued> {
    out.lines()
        .filter_map(|l| {
            let mut f = l.trim().splitn(3, '|');
            let (id, state, reason) = (f.next()?, f.next()?, f.next().unwrap_or(""));
            (!id.is_empty()).then(|| Queued { id: id.into(), state: state.into(), reason: reason.trim().into() })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_ids_and_queue_lines_parse() {
        assert_eq!(parse_job_id("1234\n").unwrap(), "1234");
        assert_eq!(parse_job_id("77;cluster\n").unwrap(), "77");
        assert!(parse_job_id("sbatch: error: x").is_err());
        assert!(parse_job_id("").is_err());
        let q = parse_queue("12_1|RUNNING|None\n12_[2-3]|PENDING|Resources\n13|PENDING|DependencyNeverSatisfied\n\n");
        assert_eq!(q.len(), 3);
        assert_eq!(q[0], Queued { id: "12_1".into(), state: "RUNNING".into(), reason: "None".into() });
        assert!(!q[1].never_starts() && q[2].never_starts());
    }
}
