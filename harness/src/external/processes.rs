//! A run's processes as `/proc` shows them: who is below whom, their memory and CPU time, and
//! what their folder holds. The sandbox measures the solver with it from outside; nothing here
//! takes a number from the solver.

use std::collections::BTreeMap;
use std::path::Path;

/// What `/proc/<pid>/stat` says of a process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stat {
    pub parent: i32,
    pub group: i32,
    /// User + system CPU time of the process itself (not of its waited children), clock ticks.
    pub cpu_ticks: u64,
    /// When it started, clock ticks after boot: with the pid, it names the process even when
    /// its pid is used again.
    pub start: u64,
}

/// Parse a `/proc/<pid>/stat` line; the command (field 2) is parenthesized and may hold spaces
/// and parentheses, so the fields are counted from its last `)`.
pub fn parse_stat(line: &str) -> Option<Stat> {
    let rest = &line[line.rfind(')')? + 1..];
    // After the command: state (3), parent (4), group (5), ..., utime (14), stime (15), ...,
    // starttime (22).
    let f: Vec<&str> = rest.split_whitespace().collect();
    let field = |n: usize| -> Option<u64> { f.get(n - 3)?.parse().ok() };
    Some(Stat {
        parent: f.get(1)?.parse().ok()?,
        group: f.get(2)?.parse().ok()?,
        cpu_ticks: field(14)? + field(15)?,
        start: field(22)?,
    })
}

pub fn stat(pid: i32) -> Option<Stat> {
    parse_stat(&std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?)
}

/// Every process of the machine with its stat (none where there is no `/proc`).
pub fn all() -> Vec<(i32, Stat)> {
    let Ok(dir) = std::fs::read_dir("/proc") else { return Vec::new() };
    dir.flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<i32>().ok())
        .filter_map(|pid| Some((pid, stat(pid)?)))
        .collect()
}

/// The processes of `all` below `root` (zombies included), from their parent links.
pub fn below(root: i32, all: &[(i32, Stat)]) -> Vec<(i32, Stat)> {
    let mut children: BTreeMap<i32, Vec<(i32, Stat)>> = BTreeMap::new();
    for &(pid, s) in all {
        children.entry(s.parent).or_default().push((pid, s));
    }
    let mut found = Vec::new();
    let mut todo = vec![root];
    while let Some(p) = todo.pop() {
        for &(c, s) in children.get(&p).map_or(&[][..], |v| &v[..]) {
            if c != root && !found.iter().any(|&(f, _)| f == c) {
                found.push((c, s));
                todo.push(c);
            }
        }
    }
    found.sort_by_key(|&(pid, _)| pid);
    found
}

/// A process's resident memory now (`VmRSS`) and its peak (`VmHWM`), KiB.
pub fn memory_kb(pid: i32) -> Option<(u64, u64)> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        line.split_whitespace().nth(1)?.parse().ok()
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// What was seen of a run's processes over its samples, each process named by its pid and
/// start time.
#[derive(Debug, Default)]
pub struct Seen {
    /// Each process's peak resident memory, KiB.
    peaks_kb: BTreeMap<(i32, u64), u64>,
    /// Each process's own CPU time when last seen, clock ticks.
    cpu_ticks: BTreeMap<(i32, u64), u64>,
}

impl Seen {
    /// Take one sample of `processes`; their resident memory together now, KiB.
    pub fn sample(&mut self, processes: &[(i32, Stat)]) -> u64 {
        let mut resident = 0;
        for &(pid, s) in processes {
            let key = (pid, s.start);
            let ticks = self.cpu_ticks.entry(key).or_default();
            *ticks = (*ticks).max(s.cpu_ticks);
            if let Some((now, high)) = memory_kb(pid) {
                let peak = self.peaks_kb.entry(key).or_default();
                *peak = (*peak).max(high);
                resident += now;
            }
        }
        resident
    }

    /// The sum of each process's peak resident memory, MiB (`None`: none was seen).
    pub fn peak_rss_mb(&self) -> Option<f64> {
        (!self.peaks_kb.is_empty()).then(|| self.peaks_kb.values().sum::<u64>() as f64 / 1024.0)
    }

    /// The CPU time of every process seen, each as last seen, seconds: it counts processes whose
    /// parent never waits for them (their time reaches no `getrusage`), and misses what each did
    /// after its last sample.
    pub fn cpu_s(&self) -> f64 {
        let hz = nix::unistd::sysconf(nix::unistd::SysconfVar::CLK_TCK).ok().flatten().unwrap_or(100).max(1);
        self.cpu_ticks.values().sum::<u64>() as f64 / hz as f64
    }
}

/// The disk space the files beneath `folder` take, KiB (allocated blocks, so a sparse file
/// counts what it holds); links are not followed. A folder closed to us (`chmod 000`) is opened
/// again: the solver's files are our user's, and what it hides would not count.
pub fn folder_kb(folder: &Path) -> u64 {
    use std::os::unix::fs::MetadataExt;
    let mut total = 0;
    let mut todo = vec![folder.to_path_buf()];
    while let Some(dir) = todo.pop() {
        let Some(entries) = read_dir_opened(&dir) else { continue };
        for entry in entries.flatten() {
            let Ok(meta) = entry.metadata() else { continue };
            total += meta.blocks() / 2;
            if meta.is_dir() {
                todo.push(entry.path());
            }
        }
    }
    total
}

/// `dir`'s entries; when its permissions refuse them, after giving its owner every permission.
fn read_dir_opened(dir: &Path) -> Option<std::fs::ReadDir> {
    use std::os::unix::fs::PermissionsExt;
    match std::fs::read_dir(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700)).ok()?;
            std::fs::read_dir(dir).ok()
        }
        r => r.ok(),
    }
}

/// Remove `folder` and everything beneath, its folders opened first where the solver closed
/// them (`remove_dir_all` cannot empty a folder it may not read).
pub fn remove_folder(folder: &Path) -> std::io::Result<()> {
    if std::fs::remove_dir_all(folder).is_ok() || !folder.exists() {
        return Ok(());
    }
    let mut todo = vec![folder.to_path_buf()];
    while let Some(dir) = todo.pop() {
        let Some(entries) = read_dir_opened(&dir) else { continue };
        for entry in entries.flatten() {
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                todo.push(entry.path());
            }
        }
    }
    std::fs::remove_dir_all(folder)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stat_line_reads_past_a_command_with_spaces_and_parentheses() {
        // fields 3.. of a real line, the command made hostile
        let line = "4242 (a) b (c) R 17 4242 4242 0 -1 4194560 120 0 0 0 250 31 0 0 20 0 1 0 987654 1000 10";
        assert_eq!(parse_stat(line), Some(Stat { parent: 17, group: 4242, cpu_ticks: 281, start: 987654 }));
        assert_eq!(parse_stat("4242 (cut"), None);
    }

    #[test]
    fn the_tree_below_a_process_follows_parent_links_only() {
        let s = |parent| Stat { parent, group: 0, cpu_ticks: 0, start: 0 };
        let all = [(1, s(0)), (10, s(1)), (11, s(10)), (12, s(11)), (20, s(1)), (13, s(10))];
        let pids: Vec<i32> = below(10, &all).iter().map(|&(p, _)| p).collect();
        assert_eq!(pids, [11, 12, 13]);
        assert!(below(12, &all).is_empty());
    }

    #[test]
    fn this_process_is_seen_with_its_memory_and_cpu() {
        let me = std::process::id() as i32;
        let spin = std::time::Instant::now();
        while spin.elapsed() < std::time::Duration::from_millis(30) {}
        let now = stat(me).unwrap();
        let mut seen = Seen::default();
        assert!(seen.sample(&[(me, now)]) > 0);
        assert!(seen.peak_rss_mb().is_some_and(|mb| mb > 0.0));
        let once = seen.cpu_s();
        assert!(once > 0.0);
        // an older sample of the same process changes nothing; a pid used again is another process
        seen.sample(&[(me, Stat { cpu_ticks: now.cpu_ticks - 1, ..now })]);
        assert_eq!(seen.cpu_s(), once);
        seen.sample(&[(me, Stat { start: now.start + 1, ..now })]);
        assert_eq!(seen.cpu_s(), 2.0 * once);
    }

    #[test]
    fn a_folder_counts_its_files_and_subfolders_closed_or_not() {
        use std::os::unix::fs::PermissionsExt;
        // bytes no file system compresses much
        let noise =
            |n: usize| (0..n as u64).map(|i| (i.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 56) as u8).collect::<Vec<u8>>();
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(tmp.path().join("maps/hidden")).unwrap();
        std::fs::write(tmp.path().join("a"), noise(300_000)).unwrap();
        std::fs::write(tmp.path().join("maps/b"), noise(200_000)).unwrap();
        std::fs::write(tmp.path().join("maps/hidden/c"), noise(100_000)).unwrap();
        let closed = std::fs::Permissions::from_mode(0o000);
        std::fs::set_permissions(tmp.path().join("maps/hidden"), closed).unwrap();
        // at least what the files hold, at most what a file system may set aside beside it
        let kb = folder_kb(tmp.path());
        assert!((585..4096).contains(&kb), "{kb}");
        assert_eq!(folder_kb(&tmp.path().join("nowhere")), 0);
        std::fs::set_permissions(tmp.path().join("maps/hidden"), std::fs::Permissions::from_mode(0o000)).unwrap();
        remove_folder(&tmp.path().join("maps")).unwrap();
        assert!(!tmp.path().join("maps").exists());
    }
}
