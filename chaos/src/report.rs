//! What a campaign records (`chaos.json`): actions, runs, totals; the detection limit and
//! the campaign's pass/fail.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;
use vbap_mission::rundir::Percentiles;

use super::procs::Slot;

/// One action of the campaign and how it went.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Action {
    /// "kill" or "stop".
    pub action: String,
    /// "vehicle_agent 2", "coordinator", "field_server"; "" when not sent.
    pub target: String,
    /// The vehicle, for an agent.
    pub vehicle: Option<u32>,
    pub pid: Option<u32>,
    /// Planned wall time, s after the process set was up.
    pub planned_s: f64,
    /// Wall time it was sent, s after the process set was up.
    pub at_s: Option<f64>,
    /// Wall time it was sent, s since the Unix epoch.
    pub at_unix_s: Option<f64>,
    /// SIGSTOP: the pause before SIGCONT, s.
    pub pause_s: Option<f64>,
    pub sent: bool,
    /// Judged (see the module documentation).
    pub judged: bool,
    pub detected: Option<bool>,
    /// Mission time of the `lost` event, s.
    pub detected_t: Option<f64>,
    /// Wall time from the signal to the detection, ms.
    pub detection_ms: Option<f64>,
    /// Wall time from the signal to a new process in the slot, ms.
    pub restarted_ms: Option<f64>,
    pub rejoined: Option<bool>,
    /// Mission time of the `rejoin` event, s.
    pub rejoin_t: Option<f64>,
    pub reconfigured: Option<bool>,
    pub recovered: Option<bool>,
    /// SIGSTOP: still alive when continued.
    pub survived: Option<bool>,
    /// SIGSTOP: its vehicle was declared lost.
    pub declared_lost: Option<bool>,
    /// "ok", "not sent: …", "unjudged: …" or what failed.
    pub outcome: String,
    /// The compound fault this action is part of (`args::Compound::name`), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compound: Option<String>,
    /// The actions of one compound fault share a group (internal).
    #[serde(skip)]
    pub(super) group: Option<usize>,
    /// The target kind a compound fault's action must hit, whatever `--targets` says
    /// (internal).
    #[serde(skip)]
    pub(super) forced: Option<super::procs::Target>,
    /// Wall time of SIGCONT, s since the Unix epoch (internal).
    #[serde(skip)]
    pub(super) cont_unix_s: Option<f64>,
    #[serde(skip)]
    pub(super) slot: Option<Slot>,
}

impl Action {
    pub(super) fn failed(&self) -> bool {
        self.sent && self.judged && self.outcome != "ok"
    }
}

/// One run of the campaign.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunReport {
    pub index: usize,
    /// True for the lockstep calibration run (no actions).
    pub calibration: bool,
    pub pace: String,
    pub policy: String,
    pub seed: u64,
    pub mission_name: String,
    pub run_dir: PathBuf,
    pub expected_ticks: u64,
    pub exit_code: Option<i32>,
    pub wall_s: f64,
    pub ticks: Option<u64>,
    pub late_ticks: Option<u64>,
    pub vehicles_lost: Option<u64>,
    pub vehicles_rejoined: Option<u64>,
    pub reconfigurations: Option<u64>,
    /// The coordinator's own `detection_latency_ms`.
    pub coordinator_detection_ms: Vec<f64>,
    /// The coordinator's own `rejoin_latency_ms`.
    pub coordinator_rejoin_ms: Vec<f64>,
    pub verdict: String,
    pub reasons: Vec<String>,
    /// Processes the supervisor started in a slot after its first, per kind
    /// (`agents`, `coordinator`, `field_server`): every restart, asked for or not.
    pub restarts_seen: BTreeMap<String, usize>,
    pub leftover_files: Vec<PathBuf>,
    pub leftover_processes: Vec<String>,
    pub actions: Vec<Action>,
    /// Why this run fails the campaign (empty: it does not).
    pub failures: Vec<String>,
}

/// Totals over the campaign.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Totals {
    pub runs: usize,
    pub runs_failed: usize,
    pub kills_sent: usize,
    pub kills_judged: usize,
    pub kills_detected: usize,
    pub kills_undetected: usize,
    pub kills_recovered: usize,
    pub stops_sent: usize,
    pub stops_ok: usize,
    pub not_sent: usize,
    pub unjudged: usize,
    /// Judged actions whose outcome is not "ok".
    pub actions_failed: usize,
    /// Detected kills of agents with a detection latency.
    pub agent_detection_n: usize,
    /// Over the detected kills of agents, ms (the campaign's measure).
    pub agent_detection_ms: Percentiles,
    /// The coordinators' own `detection_latency_ms`, every run pooled.
    pub coordinator_detection_n: usize,
    /// Over the coordinators' own `detection_latency_ms`, ms.
    pub coordinator_detection_ms: Percentiles,
    /// Detected kills of the coordinator and field server.
    pub restart_n: usize,
    /// Over the detected kills of the coordinator and field server, ms.
    pub restart_ms: Percentiles,
    pub late_ticks: u64,
    pub leftover_files: usize,
    pub leftover_processes: usize,
    /// Actions of compound faults sent, and of them judged and failed.
    pub compound_sent: usize,
    pub compound_failed: usize,
}

/// `chaos.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Campaign {
    pub mission: String,
    pub command: String,
    pub started_utc: String,
    pub host: String,
    pub seed: u64,
    pub kills_per_run: usize,
    pub stops_per_run: usize,
    pub compound_per_run: usize,
    pub paces: Vec<String>,
    pub policies: Vec<String>,
    pub targets: Vec<String>,
    pub window_s: f64,
    pub tail_s: f64,
    pub margin_s: f64,
    /// `--max-detection-ms`, when given.
    pub max_detection_ms: Option<f64>,
    pub vehicles: usize,
    /// Lockstep speed measured by the calibration run, ticks per wall second.
    pub lockstep_ticks_per_s: Option<f64>,
    pub wall_s: f64,
    pub runs: Vec<RunReport>,
    pub totals: Totals,
    pub passed: bool,
    pub failures: Vec<String>,
}

/// The line of a failed action in the failures of its run: "kill of vehicle_agent 2 at
/// 1.23 s: not detected".
pub(super) fn action_failure(a: &Action) -> String {
    format!(
        "{} of {} at {:.2} s: {}",
        a.action,
        a.target,
        a.at_s.unwrap_or(0.0),
        a.outcome
    )
}

/// Fails every judged kill of `r` detected later than `limit` ms (`--max-detection-ms`).
pub(super) fn apply_detection_limit(r: &mut RunReport, limit: f64) {
    for a in r
        .actions
        .iter_mut()
        .filter(|a| a.sent && a.judged && a.action == "kill")
    {
        let Some(ms) = a.detection_ms.filter(|ms| *ms > limit) else {
            continue;
        };
        let slow = format!("detected after {ms:.0} ms > --max-detection-ms {limit}");
        a.outcome = if a.outcome == "ok" {
            slow
        } else {
            format!("{}; {slow}", a.outcome)
        };
        r.failures.push(action_failure(a));
    }
}

/// Totals, pass/fail.
pub(super) fn judge(c: &mut Campaign) {
    let mut t = Totals {
        runs: c.runs.len(),
        ..Totals::default()
    };
    let mut agent_ms = Vec::new();
    let mut restart_ms = Vec::new();
    let mut failures = Vec::new();
    for r in &c.runs {
        if !r.failures.is_empty() {
            t.runs_failed += 1;
            for f in &r.failures {
                failures.push(format!(
                    "run {:03} ({}, {}): {f}",
                    r.index, r.pace, r.policy
                ));
            }
        }
        t.late_ticks += r.late_ticks.unwrap_or(0);
        t.leftover_files += r.leftover_files.len();
        t.leftover_processes += r.leftover_processes.len();
        for a in &r.actions {
            t.count(a, &mut agent_ms, &mut restart_ms);
        }
    }
    let mut own: Vec<f64> = c
        .runs
        .iter()
        .flat_map(|r| r.coordinator_detection_ms.iter().copied())
        .collect();
    t.agent_detection_n = agent_ms.len();
    t.agent_detection_ms = Percentiles::of(&mut agent_ms);
    t.coordinator_detection_n = own.len();
    t.coordinator_detection_ms = Percentiles::of(&mut own);
    t.restart_n = restart_ms.len();
    t.restart_ms = Percentiles::of(&mut restart_ms);
    c.totals = t;
    c.passed = failures.is_empty();
    c.failures = failures;
}

impl Totals {
    /// Counts action `a`; its detection latency (ms) into `agent_ms` or `restart_ms`.
    fn count(&mut self, a: &Action, agent_ms: &mut Vec<f64>, restart_ms: &mut Vec<f64>) {
        if !a.sent {
            self.not_sent += 1;
            return;
        }
        if !a.judged {
            self.unjudged += 1;
        }
        if a.failed() {
            self.actions_failed += 1;
        }
        if a.compound.is_some() {
            self.compound_sent += 1;
            self.compound_failed += usize::from(a.failed());
        }
        if a.action != "kill" {
            self.stops_sent += 1;
            if a.outcome == "ok" {
                self.stops_ok += 1;
            }
            return;
        }
        self.kills_sent += 1;
        if a.judged {
            self.kills_judged += 1;
            if a.detected == Some(true) {
                self.kills_detected += 1;
            } else {
                self.kills_undetected += 1;
            }
            if a.recovered == Some(true) {
                self.kills_recovered += 1;
            }
        }
        if let Some(ms) = a.detection_ms {
            if a.vehicle.is_some() {
                agent_ms.push(ms);
            } else {
                restart_ms.push(ms);
            }
        }
    }
}
