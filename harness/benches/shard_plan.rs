//! How long planning shards takes at a cluster's scale: 100,000 runs of mixed cost (four
//! decades, log-uniform) into 1,000 shards by `plan::balance` (LPT), the median of 5 plans,
//! with the predicted makespan against the lower bound. `cargo bench -p mapbench --bench
//! shard_plan`; `cargo test --all-targets` runs it once.

use mapbench::plan::balance::plan;
use std::time::Instant;

fn main() {
    let (runs, shards) = (100_000, 1000);
    let mut x: u64 = 7;
    let costs: Vec<f64> = (0..runs)
        .map(|_| {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            10f64.powf(-2.0 + 4.0 * ((x >> 11) as f64 / (1u64 << 53) as f64))
        })
        .collect();
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..5 {
        let t = Instant::now();
        let p = plan(&costs, shards);
        times.push(t.elapsed().as_secs_f64());
        last = Some(p);
    }
    times.sort_by(f64::total_cmp);
    let p = last.expect("planned");
    let placed: usize = p.shards.iter().map(Vec::len).sum();
    assert_eq!(placed, runs, "every run in one shard");
    println!(
        "shard_plan: {runs} runs into {shards} shards in {:.3} s (median of 5, min {:.3}); makespan {:.1} = {:.4} x the lower bound {:.1}",
        times[2],
        times[0],
        p.makespan(),
        p.makespan() / p.lower_bound,
        p.lower_bound
    );
}
