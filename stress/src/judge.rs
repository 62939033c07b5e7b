//! The judge: does a flown mission pass, by the truth (`summary.json` and `truth.csv`, both
//! computed from the vehicles' TRUE states), and if not, which criterion failed.
//!
//! The criteria, in the order they are reported (docs/STRESS.md):
//! 1. `near_collision`: `formation.near_collision_ticks` > 0 (two vehicles closer than the
//!    summary's `near_collision_ratio` × spacing at some tick).
//! 2. `out_of_formation`: some survivor out of formation at the end
//!    (`formation.out_of_formation_at_end` not empty).
//! 3. `v_bound`: the true V ÷ V_U (`truth.csv` column `V_true_over_VU`) above the bound
//!    (`--v-bound`, default 2) at some row with t ≥ `formation.all_in_contact_t` (every
//!    vehicle heard from at least once; a vehicle that has not surfaced yet flies its
//!    deployment plan). Never all in contact: every row counts. Without `truth.csv` the
//!    summary's whole-run maximum `formation.max_V_true_over_VU` is used (conservative).
//! 4. `body`: the body did not get where it should. It passes when `converged`, or the
//!    verdict begins with "converged" (the body ended within the tolerance: `converged,
//!    formation broken` and `converged, near collisions` fail criteria 1–2 instead); or the
//!    field has no optimum (verdict `formation kept` / `formation broken`: a front, which
//!    the body crosses for ever); or the verdict is `converged to a stationary point`; or
//!    the verdict is `stalled` (or `stalled, formation broken`, whose formation is criterion
//!    2's) and the stall's reason (`why: …` in `reasons`) is not V
//!    (`V above V_U`, `V above V_U/2`): a body that stops on a flat or a local bump, or
//!    holds for reports, stopped for a reason of the field or the links, not because its
//!    formation was deformed. Everything else fails: `not converged` (out of time),
//!    `diverged`, a stall because of V, `interrupted`.
//! 5. `error`: the flight itself failed (no summary), or the summary has no formation.

use std::path::Path;

use serde::{Deserialize, Serialize};
use vbap_mission::rundir::Summary;

/// The criteria, in reporting order.
pub const CRITERIA: [&str; 5] = [
    "near_collision",
    "out_of_formation",
    "v_bound",
    "body",
    "error",
];

/// The judgement of one flight.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Judgement {
    /// The criteria failed, in [`CRITERIA`] order; empty = pass.
    pub failed: Vec<String>,
    /// Largest true V ÷ V_U after first contact (see the module docs).
    pub v_after_contact: f64,
    /// The run's verdict.
    pub verdict: String,
    /// One line on why, for the table of failures.
    pub why: String,
}

impl Judgement {
    /// True when no criterion failed.
    pub fn pass(&self) -> bool {
        self.failed.is_empty()
    }
    /// The judgement of a flight that failed to fly.
    pub fn error(message: &str) -> Judgement {
        Judgement {
            failed: vec!["error".into()],
            v_after_contact: 0.0,
            verdict: "error".into(),
            why: message.to_string(),
        }
    }
}

/// The largest `V_true_over_VU` of `truth.csv` text at rows with t ≥ `from` (s); `None`
/// when the text has no such column.
pub fn max_v_after(truth_csv: &str, from: f64) -> Option<f64> {
    let mut lines = truth_csv.lines();
    let header: Vec<&str> = lines.next()?.split(',').collect();
    let t_col = header.iter().position(|h| h.trim() == "t")?;
    let v_col = header.iter().position(|h| h.trim() == "V_true_over_VU")?;
    let mut max = 0.0f64;
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let (Some(t), Some(v)) = (cells.get(t_col), cells.get(v_col)) else {
            continue;
        };
        let (Ok(t), Ok(v)) = (t.trim().parse::<f64>(), v.trim().parse::<f64>()) else {
            continue;
        };
        if t >= from && v.is_finite() {
            max = max.max(v);
        } else if t >= from && v.is_nan() {
            // No formation members at that tick: nothing to judge.
        } else if t >= from {
            max = f64::INFINITY;
        }
    }
    Some(max)
}

/// The reason of an end-of-run stall, from the `reasons` of the summary (`why: X)`).
pub fn stall_why(summary: &Summary) -> Option<String> {
    summary.reasons.iter().find_map(|r| {
        let at = r.find("the body stalled from")?;
        let rest = &r[at..];
        let why = rest.split("why: ").nth(1)?;
        Some(why.trim_end_matches(')').to_string())
    })
}

/// Judges a flight from its summary and the text of its `truth.csv` (if any) against the
/// bound `v_bound` on V ÷ V_U.
pub fn judge(summary: &Summary, truth_csv: Option<&str>, v_bound: f64) -> Judgement {
    let Some(f) = &summary.formation else {
        return Judgement::error("summary.json has no formation figures");
    };
    let mut failed = Vec::new();
    let mut why = Vec::new();
    if f.near_collision_ticks > 0 {
        failed.push("near_collision".to_string());
        why.push(format!(
            "{} near-collision ticks (closest {:.3} spacing)",
            f.near_collision_ticks,
            f.min_pair_ratio.unwrap_or(f64::NAN)
        ));
    }
    if !f.out_of_formation_at_end.is_empty() {
        failed.push("out_of_formation".to_string());
        why.push(format!(
            "{} of {} out of formation at the end",
            f.out_of_formation_at_end.len(),
            f.alive_at_end
        ));
    }
    let from = f.all_in_contact_t.unwrap_or(0.0);
    let v = truth_csv
        .and_then(|t| max_v_after(t, from))
        .unwrap_or(f.max_v_true_over_vu);
    if v > v_bound {
        failed.push("v_bound".to_string());
        why.push(format!(
            "V/V_U {} after first contact (t ≥ {from:.2} s), bound {v_bound}",
            if v.is_finite() {
                format!("{v:.3}")
            } else {
                "not finite".into()
            }
        ));
    }
    let stall = stall_why(summary);
    let body_ok = summary.converged
        || summary.verdict.starts_with("converged")
        || summary.verdict == "formation kept"
        || summary.verdict == "formation broken"
        || summary.verdict == "converged to a stationary point"
        // Theorem 5.1: under noise the body converges to the set M, not to the optimum; a
        // body that ended in M (and did not move away, nor break its formation) has what
        // the paper guarantees, whatever the mission's tolerance.
        || (summary.verdict == "not converged" && summary.in_set_m == Some(true))
        || (summary.verdict.starts_with("stalled")
            && stall
                .as_deref()
                .is_some_and(|w| w != "V above V_U" && w != "V above V_U/2"));
    if !body_ok {
        failed.push("body".to_string());
        why.push(format!(
            "verdict {:?}{}, {:.3} from the optimum{}",
            summary.verdict,
            stall.map_or(String::new(), |w| format!(" (stall: {w})")),
            summary.final_distance_to_optimum.unwrap_or(f64::NAN),
            if summary.in_set_m == Some(true) {
                " (inside the set M of Theorem 5.1)"
            } else {
                ""
            }
        ));
    }
    Judgement {
        failed,
        v_after_contact: v,
        verdict: summary.verdict.clone(),
        why: why.join("; "),
    }
}

/// Judges the run directory `dir` whose flight returned `summary`.
pub fn judge_dir(summary: &Summary, dir: &Path, v_bound: f64) -> Judgement {
    let truth = std::fs::read_to_string(dir.join("truth.csv")).ok();
    judge(summary, truth.as_deref(), v_bound)
}
