//! `references`: the reference minima a config's runs are judged by, computed, lowered and
//! listed.

use super::args::ReferencesArgs;
use anyhow::Result;
use mapbench::plan::config::LoadedConfig;
use mapbench::plan::Plan;
use mapbench::run::progress;
use mapbench::signals;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// `references`: compute the reference minima no store holds yet, lower them with the maps of
/// the run folders `from`, and list them.
pub(crate) fn references(a: ReferencesArgs) -> Result<ExitCode> {
    let ReferencesArgs { config, only, store, from, recertify } = a;
    let (config, only, from) = (config.as_path(), only.globs.as_slice(), from.as_slice());
    let interrupt = Arc::new(AtomicBool::new(false));
    let signal = signals::on_interrupt(interrupt.clone());
    let mut plan = Plan::resolve(LoadedConfig::load(config)?, only)?;
    let Some(stores) = plan.references.as_mut() else {
        anyhow::bail!("{}: the config has no reference stores", config.display());
    };
    if let Some(p) = store {
        stores.store = p;
    }
    // Computing them is this verb's job, whatever the config says of its batches.
    stores.compute = true;
    let store = stores.store.clone();
    for n in &plan.notices {
        eprintln!("{n}");
    }
    let runs: Vec<&mapbench::plan::PlannedRun> = plan.runs.iter().collect();
    let progress = progress::for_stderr();
    let notice = |line: &str| progress.notice(line);
    let mut groups = mapbench::judge::reference::prepare(&plan, &runs, &notice, &interrupt)?;
    if !from.is_empty() {
        let dirs: Vec<&std::path::Path> = from.iter().map(|p| p.as_path()).collect();
        let candidates = mapbench::judge::improve::from_folders(&plan, &groups, &dirs)?;
        mapbench::judge::improve::improve(&plan, &runs, &mut groups, candidates, &notice, &interrupt)?;
    }
    if recertify {
        mapbench::judge::reference::recertify(&plan, &runs, &mut groups, &notice, &interrupt)?;
    }
    progress.finish();
    println!("dataset\tenergy\te_star\tcertified\torigin\tkey");
    for g in &groups {
        let e = g.e_star.map_or_else(|| "-".to_string(), |e| format!("{e:.15e}"));
        let certified = if g.e_star.is_none() {
            "-"
        } else if g.certified {
            "yes"
        } else {
            "no"
        };
        println!("{}\t{}\t{e}\t{certified}\t{:?}\t{}", g.dataset, g.energy, g.origin, g.key.as_deref().unwrap_or("-"));
    }
    let missing = groups.iter().filter(|g| g.e_star.is_none()).count();
    let uncertified = groups.iter().filter(|g| g.e_star.is_some() && !g.certified).count();
    use mapbench::judge::reference::Origin;
    let from = |o: &[Origin]| groups.iter().filter(|g| g.e_star.is_some() && o.contains(&g.origin)).count();
    eprintln!(
        "{} references: {} from the committed store, {} from {}, {} computed or lowered now \
         ({missing} not available, {uncertified} not certified)",
        groups.len(),
        from(&[Origin::Seed]),
        from(&[Origin::Store]),
        store.display(),
        from(&[Origin::Computed, Origin::Improved]),
    );
    let signalled = signal.load(Ordering::SeqCst);
    if signalled != 0 {
        return Ok(ExitCode::from(128 + signalled.clamp(1, 127) as u8));
    }
    Ok(if missing > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS })
}
