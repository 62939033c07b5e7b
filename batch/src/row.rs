//! One run of a batch: its row of `batch.csv`.

use std::path::PathBuf;

use serde::Serialize;
use vbap_mission::rundir::{Num, Summary};

/// One row of `batch.csv`: one run (a grid point and a seed).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SeedResult {
    pub seed: u64,
    pub converged: bool,
    pub time_to_converge_s: Option<f64>,
    pub final_distance_to_optimum: Option<f64>,
    pub final_grad_norm: Option<f64>,
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: Option<f64>,
    pub in_set_m: Option<bool>,
    pub wall_time_s: f64,
    /// "ok", or why the run failed.
    pub status: String,
    /// The run's directory.
    pub run_dir: PathBuf,
    /// The run's verdict (summary.json `verdict`).
    pub verdict: String,
    /// The formation figures of summary.json.
    #[serde(rename = "max_V_seen_over_VU")]
    pub max_v_seen_over_vu: Option<f64>,
    pub min_pair_ratio: Option<f64>,
    pub near_collision_ticks: Option<u64>,
    pub worst_slot_error: Option<f64>,
    pub alive_at_end: Option<usize>,
    pub in_formation_at_end: Option<usize>,
    pub longest_contact_gap_s: Option<f64>,
    pub stalled_s: Option<f64>,
    /// Share of ticks with the true V above V_U once every vehicle was heard.
    #[serde(rename = "share_V_above_VU_after_contact")]
    pub share_v_above_vu_after_contact: Option<f64>,
    /// Messages sent and delivered over the vehicle ↔ coordinator links (summary.json
    /// `messages`).
    pub messages_sent: Option<u64>,
    pub messages_delivered: Option<u64>,
    /// Index of the run's grid point (0 without a sweep).
    pub point: usize,
    /// The swept keys' values at the grid point, in the sweep's key order.
    pub values: Vec<String>,
}

impl SeedResult {
    /// The row of a run that wrote `s`.
    pub fn from_summary(seed: u64, s: &Summary, run_dir: PathBuf) -> Self {
        let f = s.formation.as_ref();
        Self {
            seed,
            converged: s.converged,
            time_to_converge_s: s.time_to_converge_s,
            final_distance_to_optimum: s.final_distance_to_optimum,
            final_grad_norm: Some(s.final_grad_norm),
            max_v_over_vu: Some(s.max_v_over_vu),
            in_set_m: s.in_set_m,
            wall_time_s: s.wall_time_s,
            status: "ok".into(),
            run_dir,
            verdict: s.verdict.clone(),
            max_v_seen_over_vu: f.map(|f| f.max_v_seen_over_vu),
            min_pair_ratio: f.and_then(|f| f.min_pair_ratio),
            near_collision_ticks: f.map(|f| f.near_collision_ticks),
            worst_slot_error: f.and_then(|f| f.worst_slot_error),
            alive_at_end: f.map(|f| f.alive_at_end),
            in_formation_at_end: f.map(|f| f.in_formation_at_end),
            longest_contact_gap_s: f.and_then(|f| {
                f.longest_contact_gap_s
                    .iter()
                    .flatten()
                    .copied()
                    .reduce(f64::max)
            }),
            stalled_s: f.map(|f| f.stalled_s),
            share_v_above_vu_after_contact: f
                .and_then(|f| f.share_ticks_v_true_above_vu_after_contact),
            messages_sent: Some(s.messages.sent),
            messages_delivered: Some(s.messages.delivered),
            point: 0,
            values: Vec::new(),
        }
    }

    /// The row of a run that failed for `why` after `wall` s.
    pub fn failed(seed: u64, why: String, wall: f64, run_dir: PathBuf) -> Self {
        Self {
            seed,
            wall_time_s: wall,
            status: why,
            run_dir,
            ..Self::default()
        }
    }

    /// Did the run complete (a summary was read)?
    pub fn ok(&self) -> bool {
        self.status == "ok"
    }

    /// Did the run end with every live vehicle in formation (unknown without the figures)?
    pub fn formation_intact(&self) -> Option<bool> {
        self.alive_at_end
            .zip(self.in_formation_at_end)
            .map(|(a, i)| a == i)
    }
}

/// The columns of `batch.csv` every batch has had (a sweep adds [`MORE_COLUMNS`] and a
/// column per swept key after them).
pub const BATCH_HEADER: &str = "seed,converged,time_to_converge_s,final_distance_to_optimum,final_grad_norm,max_V_over_VU,in_set_m,wall_time_s,status,verdict,max_V_seen_over_VU,min_pair_ratio,near_collision_ticks,worst_slot_error,alive_at_end,in_formation_at_end,longest_contact_gap_s,stalled_s,share_V_above_VU_after_contact";

/// The columns after [`BATCH_HEADER`]: the run's message counts.
pub const MORE_COLUMNS: &str = "messages_sent,messages_delivered";

/// The header line of `batch.csv` for a sweep over `keys` (none: no sweep).
pub fn header(keys: &[String]) -> String {
    let mut h = format!("{BATCH_HEADER},{MORE_COLUMNS}");
    for k in keys {
        h.push(',');
        h.push_str(&quote(k));
    }
    h
}

/// A CSV cell: quoted when it holds a comma, a quote or a line break.
pub fn quote(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\"").replace('\n', " "))
    } else {
        text.to_string()
    }
}

/// The row of `r` in `batch.csv` (no line break).
pub fn csv_row(r: &SeedResult) -> String {
    fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
        v.map(|v| v.to_string()).unwrap_or_default()
    }
    let status = quote(&r.status);
    let verdict = quote(&r.verdict);
    let mut row = format!(
        "{},{},{},{},{},{},{},{},{status},{verdict},{},{},{},{},{},{},{},{},{},{},{}",
        r.seed,
        r.converged,
        opt(r.time_to_converge_s.map(Num)),
        opt(r.final_distance_to_optimum.map(Num)),
        opt(r.final_grad_norm.map(Num)),
        opt(r.max_v_over_vu.map(Num)),
        opt(r.in_set_m),
        Num(r.wall_time_s),
        opt(r.max_v_seen_over_vu.map(Num)),
        opt(r.min_pair_ratio.map(Num)),
        opt(r.near_collision_ticks),
        opt(r.worst_slot_error.map(Num)),
        opt(r.alive_at_end),
        opt(r.in_formation_at_end),
        opt(r.longest_contact_gap_s.map(Num)),
        opt(r.stalled_s.map(Num)),
        opt(r.share_v_above_vu_after_contact.map(Num)),
        opt(r.messages_sent),
        opt(r.messages_delivered),
    );
    for v in &r.values {
        row.push(',');
        row.push_str(&quote(v));
    }
    row
}
