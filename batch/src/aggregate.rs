//! `batch.json`: the whole batch's aggregate and its pass/fail judgment.

use serde::Serialize;

use super::criteria::Criteria;
use super::points::PointAggregate;
use super::row::SeedResult;
use super::stats::{rate_of, Distribution};
use super::sweep::SweptKey;

/// `batch.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Aggregate {
    pub mission: String,
    pub mode: String,
    pub first_seed: u64,
    pub runs: usize,
    pub completed: usize,
    pub failed_runs: usize,
    pub converged: usize,
    pub convergence_rate: f64,
    /// Over the converged runs, s.
    pub time_to_converge_s: Distribution,
    /// Over the completed runs that have an optimum.
    pub final_distance_to_optimum: Distribution,
    /// Over the completed runs.
    pub final_grad_norm: Distribution,
    /// Over the completed runs.
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: Distribution,
    /// Fraction of the completed runs that ended in the set M of Theorem 5.1.
    pub in_set_m_rate: Option<f64>,
    /// Share of the runs (all, failed ones included) per verdict.
    pub verdicts: std::collections::BTreeMap<String, f64>,
    /// Fraction of the completed runs that ended with every live vehicle in formation.
    pub formation_kept_rate: Option<f64>,
    /// Fraction of the completed runs with at least one near-collision tick.
    pub near_collision_rate: Option<f64>,
    /// Fraction of the completed runs that stalled at some point.
    pub stall_rate: Option<f64>,
    /// Over the completed runs: the coordinator's own max V/V_U, the closest pair and the
    /// worst slot error (÷ design spacing).
    #[serde(rename = "max_V_seen_over_VU")]
    pub max_v_seen_over_vu: Distribution,
    pub min_pair_ratio: Distribution,
    pub worst_slot_error: Distribution,
    /// Wall time per run, s.
    pub wall_time_s: Distribution,
    /// Wall time of the whole batch, s.
    pub batch_wall_time_s: f64,
    pub jobs: usize,
    pub criteria: Criteria,
    pub passed: bool,
    /// Every failed criterion, in words.
    pub failures: Vec<String>,
    /// The swept keys and their values (empty without a sweep).
    pub sweep: Vec<SweptKey>,
    /// The figures of every grid point (one without a sweep), in grid order.
    pub points: Vec<PointAggregate>,
}

/// Aggregates the rows and judges them against `criteria`.
pub fn aggregate(rows: &[SeedResult], criteria: &Criteria) -> Aggregate {
    let done: Vec<&SeedResult> = rows.iter().filter(|r| r.ok()).collect();
    let converged: Vec<&SeedResult> = done.iter().copied().filter(|r| r.converged).collect();
    let runs = rows.len();
    let rate = if runs == 0 {
        0.0
    } else {
        converged.len() as f64 / runs as f64
    };
    let with_m: Vec<bool> = done.iter().filter_map(|r| r.in_set_m).collect();
    let mut a = Aggregate {
        runs,
        completed: done.len(),
        failed_runs: runs - done.len(),
        converged: converged.len(),
        convergence_rate: rate,
        time_to_converge_s: Distribution::of(
            converged
                .iter()
                .filter_map(|r| r.time_to_converge_s)
                .collect(),
        ),
        final_distance_to_optimum: Distribution::of(
            done.iter()
                .filter_map(|r| r.final_distance_to_optimum)
                .collect(),
        ),
        final_grad_norm: Distribution::of(done.iter().filter_map(|r| r.final_grad_norm).collect()),
        max_v_over_vu: Distribution::of(done.iter().filter_map(|r| r.max_v_over_vu).collect()),
        in_set_m_rate: (!with_m.is_empty())
            .then(|| with_m.iter().filter(|b| **b).count() as f64 / with_m.len() as f64),
        verdicts: {
            let mut m = std::collections::BTreeMap::new();
            for r in rows {
                let v = if r.ok() {
                    r.verdict.clone()
                } else {
                    "failed".to_string()
                };
                *m.entry(v).or_insert(0.0) += 1.0 / runs as f64;
            }
            m
        },
        formation_kept_rate: rate_of(&done, SeedResult::formation_intact),
        near_collision_rate: rate_of(&done, |r| r.near_collision_ticks.map(|n| n > 0)),
        stall_rate: rate_of(&done, |r| r.stalled_s.map(|s| s > 0.0)),
        max_v_seen_over_vu: Distribution::of(
            done.iter().filter_map(|r| r.max_v_seen_over_vu).collect(),
        ),
        min_pair_ratio: Distribution::of(done.iter().filter_map(|r| r.min_pair_ratio).collect()),
        worst_slot_error: Distribution::of(
            done.iter().filter_map(|r| r.worst_slot_error).collect(),
        ),
        wall_time_s: Distribution::of(rows.iter().map(|r| r.wall_time_s).collect()),
        criteria: criteria.clone(),
        ..Aggregate::default()
    };
    let failures = criteria_failures(rows, &a, criteria);
    a.passed = failures.is_empty();
    a.failures = failures;
    a
}

/// What `rows` fail: failed runs, then each criterion of `criteria` not met (aggregate
/// `a` of the rows holds the counts).
fn criteria_failures(rows: &[SeedResult], a: &Aggregate, criteria: &Criteria) -> Vec<String> {
    let done: Vec<&SeedResult> = rows.iter().filter(|r| r.ok()).collect();
    let converged: Vec<&SeedResult> = done.iter().copied().filter(|r| r.converged).collect();
    let (runs, rate) = (a.runs, a.convergence_rate);
    let mut failures = Vec::new();
    if a.failed_runs > 0 {
        let seeds: Vec<String> = rows.iter().filter(|r| !r.ok()).map(who).collect();
        failures.push(format!(
            "{} run(s) failed (seeds {})",
            a.failed_runs,
            seeds.join(", ")
        ));
    }
    if let Some(min) = criteria.min_convergence_rate {
        if rate < min {
            failures.push(format!(
                "min_convergence_rate: {} of {} seeds converged (rate {rate:.3} < {min})",
                a.converged, runs
            ));
        }
    }
    if let Some(max) = criteria.max_final_distance {
        let over: Vec<String> = done
            .iter()
            .filter(|r| r.final_distance_to_optimum.is_none_or(|d| d > max))
            .map(|r| match r.final_distance_to_optimum {
                Some(d) => format!("seed {}: {d:.4}", who(r)),
                None => format!("seed {}: no optimum to measure against", who(r)),
            })
            .collect();
        if !over.is_empty() {
            failures.push(format!(
                "max_final_distance: {} run(s) ended farther than {max} ({})",
                over.len(),
                over.join("; ")
            ));
        }
    }
    if let Some(max) = criteria.max_time_to_converge {
        let over: Vec<String> = converged
            .iter()
            .filter_map(|r| {
                r.time_to_converge_s
                    .filter(|t| *t > max)
                    .map(|t| format!("seed {}: {t} s", who(r)))
            })
            .collect();
        if !over.is_empty() {
            failures.push(format!(
                "max_time_to_converge: {} converged run(s) took longer than {max} s ({})",
                over.len(),
                over.join("; ")
            ));
        }
    }
    failures
}

/// A run in words: its seed, and its grid point's index when there is a sweep ("3 at
/// point 2").
fn who(r: &SeedResult) -> String {
    if r.values.is_empty() {
        r.seed.to_string()
    } else {
        format!("{} at point {}", r.seed, r.point)
    }
}
