//! Shards balanced by cost: the runs of a batch assigned to N shards longest first, each to
//! the shard with the least work so far (Graham's LPT rule, within 4/3 - 1/(3N) of the best
//! makespan, and in practice within a few percent of the lower bound once shards hold many
//! runs). Pure: costs in, shards out; where the costs come from is the caller's.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

/// The runs of each shard (indices into the costs, in the batch's order) and what the plan
/// predicts.
#[derive(Clone, Debug, PartialEq)]
pub struct ShardPlan {
    pub shards: Vec<Vec<usize>>,
    /// Each shard's predicted work (the sum of its runs' costs).
    pub loads: Vec<f64>,
    /// No plan can finish before this: the longest run, or the total work spread evenly.
    pub lower_bound: f64,
}

impl ShardPlan {
    /// The predicted time of the batch: its busiest shard's work.
    pub fn makespan(&self) -> f64 {
        self.loads.iter().copied().fold(0.0, f64::max)
    }
}

/// A shard's load in the heap: the least loaded first, ties to the lower index.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Load(f64, usize);

impl Eq for Load {}

impl PartialOrd for Load {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Load {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
    }
}

/// Assign runs of `costs` (seconds, or any common unit; non-finite or negative costs count
/// as 0) to `n` shards (at least 1) by LPT. Deterministic: equal costs go in the batch's order.
pub fn plan(costs: &[f64], n: usize) -> ShardPlan {
    let n = n.max(1);
    let cost = |i: usize| if costs[i].is_finite() && costs[i] > 0.0 { costs[i] } else { 0.0 };
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by(|&a, &b| cost(b).total_cmp(&cost(a)).then(a.cmp(&b)));
    let mut heap: BinaryHeap<Reverse<Load>> = (0..n).map(|s| Reverse(Load(0.0, s))).collect();
    let mut shards = vec![Vec::new(); n];
    let mut loads = vec![0.0; n];
    for i in order {
        let Some(Reverse(Load(load, s))) = heap.pop() else { break };
        shards[s].push(i);
        loads[s] = load + cost(i);
        heap.push(Reverse(Load(loads[s], s)));
    }
    for s in &mut shards {
        s.sort_unstable();
    }
    let total: f64 = (0..costs.len()).map(cost).sum();
    let longest = (0..costs.len()).map(cost).fold(0.0, f64::max);
    ShardPlan { shards, loads, lower_bound: longest.max(total / n as f64) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic mix of costs over four decades (log-uniform from 0.01 to 100), the
    /// shape of a corpus where a few large meshes and slow solvers dominate.
    pub(crate) fn mixed_costs(count: usize, seed: u64) -> Vec<f64> {
        let mut x = seed;
        (0..count)
            .map(|_| {
                // 64-bit LCG (Knuth's MMIX constants); the top 53 bits as a uniform in [0, 1).
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                10f64.powf(-2.0 + 4.0 * u)
            })
            .collect()
    }

    fn each_run_once(plan: &ShardPlan, runs: usize) {
        let mut seen = vec![0usize; runs];
        for s in &plan.shards {
            for &i in s {
                seen[i] += 1;
            }
        }
        assert!(seen.iter().all(|&k| k == 1), "a run in no shard or in two");
    }

    #[test]
    fn small_cases_by_hand() {
        // 7, 5, 4, 3, 3, 2 into 2 shards: LPT gives 7+3+2 = 12 and 5+4+3 = 12, the optimum.
        let p = plan(&[3.0, 7.0, 2.0, 5.0, 3.0, 4.0], 2);
        assert_eq!(p.shards, [vec![0, 1, 2], vec![3, 4, 5]]);
        assert_eq!((p.loads.clone(), p.makespan(), p.lower_bound), (vec![12.0, 12.0], 12.0, 12.0));
        each_run_once(&p, 6);
        // Graham's worst case for 2 shards: 3, 3, 2, 2, 2 -> 7 against the optimum 6 (4/3 - 1/6).
        let p = plan(&[3.0, 3.0, 2.0, 2.0, 2.0], 2);
        assert_eq!((p.makespan(), p.lower_bound), (7.0, 6.0));
        // One run longer than the rest together: it alone bounds the plan.
        let p = plan(&[100.0, 1.0, 1.0, 1.0], 3);
        assert_eq!((p.makespan(), p.lower_bound), (100.0, 100.0));
        // More shards than runs, no runs, bad costs, zero shards.
        let p = plan(&[1.0, 2.0], 4);
        assert_eq!(p.shards.iter().filter(|s| s.is_empty()).count(), 2);
        assert_eq!(plan(&[], 3).shards, vec![Vec::<usize>::new(); 3]);
        let p = plan(&[f64::NAN, -1.0, 2.0], 1);
        assert_eq!((p.shards.clone(), p.makespan()), (vec![vec![0, 1, 2]], 2.0));
        assert_eq!(plan(&[1.0], 0).shards.len(), 1);
        // Deterministic: equal costs keep the batch's order.
        assert_eq!(plan(&[1.0; 4], 2).shards, [vec![0, 2], vec![1, 3]]);
    }

    /// A cluster's scale: 100,000 runs of mixed cost into 1,000 shards, every run in exactly
    /// one shard and the predicted makespan within 5% of the lower bound (how long planning
    /// takes is the `shard_plan` benchmark's).
    #[test]
    fn a_hundred_thousand_runs_into_a_thousand_shards_within_five_percent_of_the_bound() {
        let costs = mixed_costs(100_000, 7);
        let p = plan(&costs, 1000);
        each_run_once(&p, costs.len());
        let ratio = p.makespan() / p.lower_bound;
        assert!(ratio <= 1.05, "makespan {} vs lower bound {} ({ratio})", p.makespan(), p.lower_bound);
        let total: f64 = costs.iter().sum();
        assert!((p.loads.iter().sum::<f64>() - total).abs() < 1e-6 * total);
    }
}
