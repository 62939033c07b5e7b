//! The figures of the analysis ([`Report`], `vbap analyze --json`) and the distributions
//! behind them ([`Distributions`], for the plots).

use std::collections::BTreeMap;

use serde::Serialize;
use vbap_wire::rundir::{AcousticTotals, Percentiles, Summary};

/// Figures of one hop (docs/ARCHITECTURE.md §10, `vbap analyze --json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct HopReport {
    /// Transport latency (receive − send wall clock − injected delay), µs.
    pub transport_us: Percentiles,
    /// Injected link delay of the delivered messages, ms (zero without a link model).
    pub injected_ms: Percentiles,
    /// Messages delivered to the receiver's logic (received and not dropped by the link
    /// model).
    pub delivered: u64,
    /// Messages dropped by the link model.
    pub dropped_injected: u64,
    /// Commands the shore replaced with a newer one (Iridium).
    #[serde(default)]
    pub superseded: u64,
    /// Messages lost to a full queue.
    pub dropped_overflow: u64,
    /// Messages received over IPC (the link model may drop some of them after).
    pub received: u64,
    /// Mean and largest size of the received messages whose records carry one, in the
    /// compact link encoding (`vbap_wire::compact`), bytes (none: no sizes recorded).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bytes_mean: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bytes_max: Option<u64>,
    /// Their bytes, summed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bytes_total: Option<u64>,
    /// Messages the link model held before delivery (`held` records; on the acoustic hop:
    /// every frame heard, held for its propagation and air time).
    pub held: u64,
    /// The acoustic hop's losses by verdict (`range`, `deaf`, `collision`, `undecoded`,
    /// `noise`); empty on the other hops.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub reasons: BTreeMap<String, u64>,
}

/// Loop timing of one process.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoopReport {
    /// Period between consecutive iterations, ms.
    pub period_ms: Percentiles,
    /// |period − nominal period|, ms.
    pub jitter_ms: Percentiles,
    /// The nominal period the jitter is measured against, ms (dt / pace factor in real
    /// time, the median period in lockstep).
    pub nominal_ms: f64,
    /// Iterations seen.
    pub iterations: u64,
}

/// The whole analysis.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    /// Per hop: `state`, `body`, `field_request`, `field_reply`.
    pub hops: BTreeMap<String, HopReport>,
    /// Per process: `coordinator`, `vehicle_agent_<id>`.
    pub loops: BTreeMap<String, LoopReport>,
    /// Ticks whose deadline passed before every state was in (real-time runs; from
    /// summary.json, 0 in lockstep).
    pub late_ticks: u64,
    /// "lockstep" or the real-time factor.
    pub pace: String,
    /// Message records read.
    pub records: u64,
    /// Message-record lines that could not be parsed.
    pub unparsed: u64,
    /// Where the time of a lockstep tick goes (None for real-time runs or too few ticks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tick: Option<TickReport>,
}

/// Where the time of a lockstep tick goes, from the coordinator's point of view: tick k
/// runs from the publication of command k − 1 to that of command k; until the last state of
/// tick k is in, the coordinator waits for the agents (none of it when they ran ahead);
/// from then on it works alone (sensor reads, link model, planner, files, checkpoint).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct TickReport {
    /// Ticks measured.
    pub ticks: u64,
    /// Command k − 1 published → command k published, µs.
    pub period_us: Percentiles,
    /// Command k − 1 published → last state of tick k received (0 when it was in before), µs.
    pub waiting_for_states_us: Percentiles,
    /// Last state of tick k received (or command k − 1 published, if later) → command k
    /// published, µs.
    pub after_last_state_us: Percentiles,
}

impl Report {
    /// Per-hop transport percentiles for `summary.json`'s `latency_us` (the hops with
    /// receptions: not the acoustic one, whose records are verdicts only).
    pub fn latency_summary(&self) -> BTreeMap<String, Percentiles> {
        self.hops
            .iter()
            .filter(|(_, v)| v.received > 0)
            .map(|(k, v)| (k.clone(), v.transport_us))
            .collect()
    }

    /// Fills the figures of the logs into `summary.json`: `latency_us` (transport, per
    /// hop) and the drop counts of `messages` (summed over hops). The coordinator's own
    /// counts (`sent`, `delivered`, `rejected`) are kept.
    pub fn fill_summary(&self, s: &mut Summary) {
        s.latency_us = self.latency_summary();
        // `messages` counts the vehicle ↔ coordinator links (state and body hops), the
        // ones the link model acts on, as `vbap sim` does: sent = every message that
        // reached its receiver's process, delivered = what the link model let through.
        let link = |h: &str| self.hops.get(h);
        let links = [link("state"), link("body")];
        s.messages.sent = links.iter().flatten().map(|h| h.received).sum();
        s.messages.delivered = links.iter().flatten().map(|h| h.delivered).sum();
        s.messages.dropped_injected = links.iter().flatten().map(|h| h.dropped_injected).sum();
        s.messages.superseded = links.iter().flatten().map(|h| h.superseded).sum();
        s.messages.dropped_overflow = self.hops.values().map(|h| h.dropped_overflow).sum();
        if let Some(a) = self.hops.get(super::records::ACOUSTIC) {
            let by = |r: &str| a.reasons.get(r).copied().unwrap_or(0);
            s.acoustic = Some(AcousticTotals {
                frame_b: s.acoustic.map_or(0, |t| t.frame_b),
                heard: a.held,
                range: by("range"),
                deaf: by("deaf"),
                collision: by("collision"),
                undecoded: by("undecoded"),
                noise: by("noise"),
            });
        }
    }
}

/// Raw distributions behind a [`Report`], for the plots.
#[derive(Clone, Debug, Default)]
pub struct Distributions {
    /// Transport latency per hop, µs, sorted.
    pub transport_us: BTreeMap<String, Vec<f64>>,
    /// Injected delay per hop, ms, sorted.
    pub injected_ms: BTreeMap<String, Vec<f64>>,
    /// (tick, period ms) per process, in tick order.
    pub periods: BTreeMap<String, Vec<(u64, f64)>>,
    /// Jitter per process, ms, sorted.
    pub jitter_ms: BTreeMap<String, Vec<f64>>,
}
