//! The sections of a mission file about what goes wrong: `[links]`, `[restart]` and
//! `[[faults]]`, with their defaults.

use serde::{Deserialize, Serialize};

/// How the surfacing windows of the vehicles are placed in time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SurfacingPhase {
    /// Vehicle i surfaces at phase i·period/N (one or a few at the surface at a time).
    #[default]
    Staggered,
    /// All vehicles surface together.
    Together,
}

/// `[links]`: the vehicle ↔ coordinator link model, both directions (docs/ARCHITECTURE.md §7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinksSection {
    /// One-way delay (s), ≥ 0.
    pub delay: f64,
    /// Uniform ± jitter on the delay (s), 0 ≤ jitter ≤ delay.
    pub jitter: f64,
    /// Probability a message is lost, 0 ≤ loss < 1.
    pub loss: f64,
    /// Surfacing period (s); 0 = always in contact.
    pub surfacing_period: f64,
    /// Time at the surface in each period (s), ≤ surfacing_period, > 0 if the period is.
    pub surfacing_window: f64,
    /// Placement of the surfacing windows: "staggered" (vehicle i at phase i·period/N) or
    /// "together".
    pub surfacing_phase: SurfacingPhase,
    /// Bursty loss (Gilbert–Elliott): probability per message of going from the good to
    /// the bad state; 0 = plain Bernoulli loss.
    pub burst_enter: f64,
    /// Gilbert–Elliott: probability per message of leaving the bad state.
    pub burst_exit: f64,
    /// Gilbert–Elliott: loss probability in the bad state (`loss` applies in the good one).
    pub burst_loss: f64,
    /// Apply the model to coordinator → vehicle messages too (false: uplink only).
    pub downlink: bool,
    /// Resolution of the positions and velocities a vehicle is told (length unit; length
    /// unit/s for velocities): 0 = exact (`f64`); > 0 = the multiples of it nearest to
    /// each value, relative to the body centre for positions, as the compact link encoding
    /// writes them (`vbap_wire::compact`, 12 bytes a vector instead of 24). The vehicles fly
    /// on the values so written.
    pub position_quantum: f64,
    /// `[links.iridium]`: the link is Iridium Short Burst Data sessions (absent: messages
    /// cross whenever the vehicle is in contact, as delay, jitter and loss say).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iridium: Option<IridiumSection>,
}

/// What a vehicle does with a message over the Iridium per-message limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Oversize {
    /// Sent as several SBD messages, one after another in the same session (counted).
    #[default]
    Split,
    /// Not sent (counted as a drop, reason `oversize`).
    Refuse,
}

/// `[links.iridium]`: Iridium Short Burst Data (SBD) between a vehicle and the shore
/// (docs/guide/links-and-faults.md). A vehicle opens a session when it surfaces and every
/// `session_interval` while at the surface (always, without a surfacing schedule); a
/// session fails with probability `session_failure` (both directions); what the shore
/// holds for a vehicle waits for its next session, the newest command replacing the older
/// ones; the reports a vehicle made since its last session go up in it, packed into
/// messages of at most `up_limit` bytes. A message of b bytes takes
/// `latency_short + (latency_full − latency_short)·b/limit` s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IridiumSection {
    /// Time between two sessions while at the surface, s, > 0.
    pub session_interval: f64,
    /// Probability that a session fails (nothing crosses; the next one is tried), [0, 1).
    pub session_failure: f64,
    /// Largest message from the vehicle (mobile-originated), bytes.
    pub up_limit: u64,
    /// Largest message to the vehicle (mobile-terminated), bytes.
    pub down_limit: u64,
    /// Time to send a message of (nearly) no bytes, s.
    pub latency_short: f64,
    /// Time to send a message at the limit, s, ≥ `latency_short`.
    pub latency_full: f64,
    /// A command over `down_limit`: split or refused.
    pub oversize: Oversize,
}

impl Default for IridiumSection {
    /// Figures of the Iridium SBD service (9602/9603 transceivers): 1960 bytes up, 1890
    /// down, about 5 s for a short message and 20 s for a full one; a session a minute at
    /// the surface, one in ten failing at sea.
    fn default() -> Self {
        Self {
            session_interval: 60.0,
            session_failure: 0.1,
            up_limit: 1960,
            down_limit: 1890,
            latency_short: 5.0,
            latency_full: 20.0,
            oversize: Oversize::Split,
        }
    }
}

impl LinksSection {
    /// The longest a vehicle able to talk may wait for its next message to cross, s, beyond
    /// the link's delay and jitter: 0, or under Iridium the sessions that likely fail in a
    /// row (until a run has probability ≤ 10⁻³), one more, and a full message's transfer.
    pub fn session_wait(&self) -> f64 {
        self.iridium.as_ref().map_or(0.0, |i| {
            let f = i.session_failure;
            let likely = if f > 0.0 {
                (1e-3f64.ln() / f.ln()).ceil().max(0.0)
            } else {
                0.0
            };
            (1.0 + likely) * i.session_interval + i.latency_full
        })
    }
}

impl Default for LinksSection {
    fn default() -> Self {
        Self {
            delay: 0.0,
            jitter: 0.0,
            loss: 0.0,
            surfacing_period: 0.0,
            surfacing_window: 0.0,
            surfacing_phase: SurfacingPhase::Staggered,
            burst_enter: 0.0,
            burst_exit: 0.5,
            burst_loss: 0.5,
            downlink: true,
            position_quantum: 0.0,
            iridium: None,
        }
    }
}

/// A restart policy of the supervisor (`[restart]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RestartPolicy {
    /// Never restart.
    Never,
    /// Restart after a failure (non-zero exit or killed by a signal).
    OnFailure,
    /// Restart whenever the process ends before the mission does.
    Always,
}

/// `[restart]`: what the supervisor does when a process of the set dies (docs/ARCHITECTURE.md §8).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RestartSection {
    /// Policy for vehicle agents.
    pub vehicles: RestartPolicy,
    /// Policy for the coordinator (a restarted coordinator resumes from its checkpoint).
    pub coordinator: RestartPolicy,
    /// Policy for the field server.
    pub field_server: RestartPolicy,
    /// Wall time before a restart (s); doubles with each restart inside the window, up to
    /// `max_backoff`.
    pub backoff: f64,
    /// Longest wall time before a restart (s): the doubling stops there (a `backoff` above
    /// it is used as it is, never doubled). A coordinator or field server killed again and
    /// again holds the whole mission for its backoff, while `max_restarts` already bounds a
    /// crash loop.
    pub max_backoff: f64,
    /// Largest number of restarts of one process inside `window`; past it, no more.
    pub max_restarts: u32,
    /// Length of the restart-counting window (s, wall time).
    pub window: f64,
}

impl Default for RestartSection {
    fn default() -> Self {
        Self {
            vehicles: RestartPolicy::Never,
            coordinator: RestartPolicy::OnFailure,
            field_server: RestartPolicy::OnFailure,
            backoff: 0.2,
            max_backoff: 0.8,
            max_restarts: 5,
            window: 60.0,
        }
    }
}

impl RestartSection {
    /// Wall time before a restart of a process restarted `restarts` times already inside
    /// the window (s): `backoff` doubled per restart, at most `max_backoff` (or `backoff`
    /// when that is the larger).
    pub fn backoff_after(&self, restarts: usize) -> f64 {
        let doubled = self.backoff * 2f64.powi(restarts.min(64) as i32);
        doubled.min(self.max_backoff.max(self.backoff))
    }
}

/// The kind of a scheduled fault (`faults[i].kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// SIGKILL the vehicle's process at `at`; restart it at `until` if given.
    Kill,
    /// Cut the vehicle's link both ways from `at` to `until` (or the end).
    LinkDown,
    /// The sensor reads `value` (or its last reading if absent) from `at` to `until`.
    SensorStuck,
    /// The sensor reads T + `value` from `at` to `until`.
    SensorBias,
}

impl FaultKind {
    /// The name used in mission files.
    pub fn as_str(self) -> &'static str {
        match self {
            FaultKind::Kill => "kill",
            FaultKind::LinkDown => "link_down",
            FaultKind::SensorStuck => "sensor_stuck",
            FaultKind::SensorBias => "sensor_bias",
        }
    }
}

/// One scheduled fault (`[[faults]]`, docs/ARCHITECTURE.md §8).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultConfig {
    /// What happens.
    pub kind: FaultKind,
    /// Which vehicle (id < vehicles.count).
    pub vehicle: u32,
    /// Mission time it starts (s), in [0, duration].
    pub at: f64,
    /// Mission time it ends (s), in (at, duration]; absent = never (for `kill`: no restart).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<f64>,
    /// `sensor_bias`: the bias (field unit, required); `sensor_stuck`: the stuck reading
    /// (optional); not used by other kinds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_restart_backoff_doubles_up_to_its_cap() {
        let r = RestartSection::default();
        let seq: Vec<f64> = (0..6).map(|n| r.backoff_after(n)).collect();
        assert_eq!(seq, vec![0.2, 0.4, 0.8, 0.8, 0.8, 0.8]);
        // A backoff above the cap is used as it is, never doubled.
        let long = RestartSection {
            backoff: 3.0,
            ..RestartSection::default()
        };
        assert_eq!(long.backoff_after(0), 3.0);
        assert_eq!(long.backoff_after(3), 3.0);
    }
}
