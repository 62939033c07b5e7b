//! `vbap analyze RUN_DIR`: timing analysis of a run from its tracing logs.
//!
//! Every receiver logs one record per message (target `vbap::msg`) with the sender's
//! wall-clock send time and its own receive time; the transport latency of a hop is
//! their difference (all processes share one host clock).

use std::collections::BTreeMap;
use std::io::BufRead;

use anyhow::{Context, Result};
use serde::Serialize;
use shared::rundir::{Percentiles, RunDir, Summary};
use shared::telemetry::MSG_TARGET;

/// Figures of one hop (DESIGN §8, `vbap analyze --json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct HopReport {
    /// Transport latency (receive − send wall clock), µs.
    pub transport_us: Percentiles,
    /// Injected link delay, ms (zero without a link model).
    pub injected_ms: Percentiles,
    /// Messages received.
    pub delivered: u64,
    /// Messages dropped by the link model.
    pub dropped_injected: u64,
    /// Messages lost to a full queue.
    pub dropped_overflow: u64,
}

/// Loop timing of one process.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoopReport {
    /// Period between consecutive receptions of the process's driving message, ms.
    pub period_ms: Percentiles,
    /// |period − median period|, ms.
    pub jitter_ms: Percentiles,
}

/// The whole analysis.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub hops: BTreeMap<String, HopReport>,
    pub loops: BTreeMap<String, LoopReport>,
    pub late_ticks: u64,
}

impl Report {
    /// Per-hop transport percentiles for `summary.json`'s `latency_us`.
    pub fn latency_summary(&self) -> BTreeMap<String, Percentiles> {
        self.hops
            .iter()
            .map(|(k, v)| (k.clone(), v.transport_us))
            .collect()
    }
}

/// Reads the logs of `dir` and computes the report.
pub fn analyze(dir: &RunDir) -> Result<Report> {
    let logs = dir.root.join("logs");
    let mut latencies: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut arrivals: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut entries: Vec<_> = std::fs::read_dir(&logs)
        .with_context(|| format!("reading {}", logs.display()))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
        .collect();
    entries.sort();
    for path in entries {
        let process = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let file =
            std::fs::File::open(&path).with_context(|| format!("opening {}", path.display()))?;
        for line in std::io::BufReader::new(file).lines() {
            let Ok(line) = line else { continue };
            if !line.contains(MSG_TARGET) {
                continue;
            }
            let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
                continue;
            };
            if v.get("target").and_then(|t| t.as_str()) != Some(MSG_TARGET) {
                continue;
            }
            let f = &v["fields"];
            let (Some(hop), Some(sent), Some(recv)) = (
                f["hop"].as_str(),
                f["sent_ns"].as_u64(),
                f["recv_ns"].as_u64(),
            ) else {
                continue;
            };
            latencies
                .entry(hop.to_string())
                .or_default()
                .push((recv as f64 - sent as f64) / 1e3);
            // An agent's loop is driven by the body commands it receives.
            if process.starts_with("vehicle_agent") && hop == "body" {
                arrivals
                    .entry(process.clone())
                    .or_default()
                    .push(recv as f64 / 1e6);
            }
        }
    }
    let mut report = Report::default();
    for (hop, mut v) in latencies {
        let delivered = v.len() as u64;
        report.hops.insert(
            hop,
            HopReport {
                transport_us: Percentiles::of(&mut v),
                delivered,
                ..Default::default()
            },
        );
    }
    for (process, mut times) in arrivals {
        times.sort_by(|a, b| a.total_cmp(b));
        let mut periods: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        let period = Percentiles::of(&mut periods.clone());
        let mut jitter: Vec<f64> = periods
            .iter_mut()
            .map(|p| (*p - period.p50).abs())
            .collect();
        report.loops.insert(
            process,
            LoopReport {
                period_ms: period,
                jitter_ms: Percentiles::of(&mut jitter),
            },
        );
    }
    if let Ok(s) = Summary::read(dir) {
        report.late_ticks = s.late_ticks;
    }
    Ok(report)
}
