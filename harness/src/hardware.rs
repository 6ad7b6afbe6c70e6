//! The machine a batch ran on, as far as it changes our times: CPU model, cores, memory, OS
//! and the instruction-set extensions our kernels' speed depends on (faer's SIMD and the
//! sparse factorization pick AVX2/FMA or AVX-512 code paths at run time). `meta.json` keeps it
//! per batch and, in a merged folder, per shard, so the report can say when shards ran on
//! different machines and only `time_norm` compares their times.

use serde::{Deserialize, Serialize};

/// A machine's fingerprint. Every field is optional on reading (older folders, other OSes).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Hardware {
    pub cpu_model: Option<String>,
    pub cores: Option<usize>,
    pub memory_mb: Option<u64>,
    pub os: Option<String>,
    pub arch: Option<String>,
    /// The speed-relevant extensions present, in a fixed order ([`EXTENSIONS`]).
    pub isa: Vec<String>,
}

/// The x86-64 extensions that change which kernels run (a fixed order: fingerprints compare).
pub const EXTENSIONS: [&str; 4] = ["avx", "avx2", "fma", "avx512f"];

impl Hardware {
    /// This machine's fingerprint; what the OS does not tell stays empty.
    pub fn detect() -> Hardware {
        let read = |path: &str| std::fs::read_to_string(path).ok();
        Hardware {
            cpu_model: read("/proc/cpuinfo").as_deref().and_then(cpu_model),
            cores: std::thread::available_parallelism().ok().map(|n| n.get()),
            memory_mb: read("/proc/meminfo").as_deref().and_then(memory_mb),
            os: os_name(read("/etc/os-release").as_deref(), read("/proc/sys/kernel/osrelease").as_deref()),
            arch: Some(std::env::consts::ARCH.to_string()),
            isa: extensions(),
        }
    }

    /// Whether two machines run our kernels alike: the same CPU model, extensions and cores
    /// (memory and OS aside, which do not change a kernel's speed).
    pub fn same_speed_class(&self, other: &Hardware) -> bool {
        (&self.cpu_model, &self.isa, self.cores, &self.arch) == (&other.cpu_model, &other.isa, other.cores, &other.arch)
    }

    /// `Intel Xeon ... (8 cores, avx2 fma)`, how the report names a machine.
    pub fn describe(&self) -> String {
        let model = self.cpu_model.as_deref().unwrap_or("unknown CPU");
        let cores = self.cores.map(|c| format!("{c} cores")).unwrap_or_else(|| "cores unknown".into());
        let isa = if self.isa.is_empty() { "no AVX".to_string() } else { self.isa.join(" ") };
        format!("{model} ({cores}, {isa})")
    }
}

/// The first `model name` of `/proc/cpuinfo` (x86), else its `Hardware`/`CPU part` line.
fn cpu_model(cpuinfo: &str) -> Option<String> {
    ["model name", "Hardware", "CPU part"].iter().find_map(|key| {
        cpuinfo.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            (k.trim() == *key && !v.trim().is_empty()).then(|| v.split_whitespace().collect::<Vec<_>>().join(" "))
        })
    })
}

/// `MemTotal` of `/proc/meminfo`, in MiB.
fn memory_mb(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let kb: u64 = parts.next()?.parse().ok()?;
    (parts.next() == Some("kB")).then_some(kb / 1024)
}

/// `PRETTY_NAME` of os-release and the kernel release: `Debian GNU/Linux 13 (trixie), Linux 6.1.0`.
fn os_name(os_release: Option<&str>, kernel: Option<&str>) -> Option<String> {
    let pretty = os_release.and_then(|t| {
        t.lines().find_map(|l| l.strip_prefix("PRETTY_NAME=").map(|v| v.trim().trim_matches('"').to_string()))
    });
    let kernel = kernel.map(|k| format!("Linux {}", k.trim())).filter(|k| k.len() > "Linux ".len());
    match (pretty, kernel) {
        (Some(p), Some(k)) => Some(format!("{p}, {k}")),
        (p, k) => p.or(k).or_else(|| Some(std::env::consts::OS.to_string())),
    }
}

/// The [`EXTENSIONS`] this CPU has.
fn extensions() -> Vec<String> {
    #[cfg(target_arch = "x86_64")]
    {
        let has = [
            std::arch::is_x86_feature_detected!("avx"),
            std::arch::is_x86_feature_detected!("avx2"),
            std::arch::is_x86_feature_detected!("fma"),
            std::arch::is_x86_feature_detected!("avx512f"),
        ];
        EXTENSIONS.iter().zip(has).filter(|(_, h)| *h).map(|(e, _)| e.to_string()).collect()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec::new()
    }
}

/// The distinct machines of a merged folder's shards (by [`Hardware::same_speed_class`]), with
/// the shards that ran on each; one entry when they all ran alike.
pub fn distinct<'a>(shards: impl IntoIterator<Item = (&'a str, &'a Hardware)>) -> Vec<(&'a Hardware, Vec<&'a str>)> {
    let mut out: Vec<(&Hardware, Vec<&str>)> = Vec::new();
    for (name, hw) in shards {
        match out.iter_mut().find(|(h, _)| h.same_speed_class(hw)) {
            Some((_, names)) => names.push(name),
            None => out.push((hw, vec![name])),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprints_parse_from_the_files_of_linux() {
        let cpuinfo = "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel name\t: Intel(R) Xeon(R)  CPU @ 2.20GHz\n\
                       flags\t\t: fpu avx2\nprocessor\t: 1\nmodel name\t: Intel(R) Xeon(R)  CPU @ 2.20GHz\n";
        assert_eq!(cpu_model(cpuinfo).as_deref(), Some("Intel(R) Xeon(R) CPU @ 2.20GHz"));
        assert_eq!(cpu_model("processor : 0\nHardware : BCM2835\n").as_deref(), Some("BCM2835"));
        assert_eq!(cpu_model("processor : 0\n"), None);
        assert_eq!(memory_mb("MemTotal:       16384000 kB\nMemFree: 1 kB\n"), Some(16000));
        assert_eq!(memory_mb("MemTotal: lots\n"), None);
        let release = "NAME=\"Debian GNU/Linux\"\nPRETTY_NAME=\"Debian GNU/Linux 13 (trixie)\"\nID=debian\n";
        assert_eq!(
            os_name(Some(release), Some("6.1.0-18-amd64\n")).as_deref(),
            Some("Debian GNU/Linux 13 (trixie), Linux 6.1.0-18-amd64")
        );
        assert_eq!(os_name(None, Some("6.1.0\n")).as_deref(), Some("Linux 6.1.0"));
        assert_eq!(os_name(Some(release), Some("  \n")).as_deref(), Some("Debian GNU/Linux 13 (trixie)"));
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn this_machine_has_a_fingerprint() {
        let hw = Hardware::detect();
        assert!(hw.cpu_model.is_some() && hw.cores.is_some_and(|c| c > 0) && hw.memory_mb.is_some(), "{hw:?}");
        assert!(hw.isa.iter().all(|e| EXTENSIONS.contains(&e.as_str())));
        assert!(hw.same_speed_class(&Hardware::detect()));
        let json = serde_json::to_string(&hw).unwrap();
        assert_eq!(serde_json::from_str::<Hardware>(&json).unwrap(), hw);
        assert_eq!(serde_json::from_str::<Hardware>("{}").unwrap(), Hardware::default());
    }

    #[test]
    fn shards_group_by_the_machines_that_run_our_kernels_alike() {
        let a =
            Hardware { cpu_model: Some("A".into()), cores: Some(8), isa: vec!["avx2".into()], ..Default::default() };
        let a_more_memory = Hardware { memory_mb: Some(64_000), ..a.clone() };
        let b = Hardware { isa: vec!["avx2".into(), "avx512f".into()], ..a.clone() };
        let groups = distinct([("1/3", &a), ("2/3", &b), ("3/3", &a_more_memory)]);
        assert_eq!(groups.len(), 2);
        assert_eq!((groups[0].1.clone(), groups[1].1.clone()), (vec!["1/3", "3/3"], vec!["2/3"]));
        assert_eq!(a.describe(), "A (8 cores, avx2)");
        assert_eq!(Hardware::default().describe(), "unknown CPU (cores unknown, no AVX)");
    }
}
