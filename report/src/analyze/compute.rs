//! The analysis from the parsed records: per-hop latency and drops, loop periods and jitter,
//! the lockstep tick breakdown.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result};
use vbap_mission::config::{Mission, Pace};
use vbap_wire::rundir::{Percentiles, RunDir, Summary};

use super::records::{log_file, read_logs, Format, HopAcc};
use super::{Distributions, HopReport, LoopReport, Report, TickReport};

/// Reads the logs of `dir` and computes the report and the distributions behind it.
pub fn compute(dir: &RunDir) -> Result<(Report, Distributions)> {
    let logs = dir.root.join("logs");
    let mut files: Vec<(PathBuf, Format, String)> = std::fs::read_dir(&logs)
        .with_context(|| format!("reading {}", logs.display()))?
        .flatten()
        .map(|e| e.path())
        .filter_map(|p| log_file(&p).map(|(format, process)| (p, format, process)))
        .collect();
    // A run over hosts: the other hosts' logs, copied to hosts/<host>/logs/, merged.
    for host in std::fs::read_dir(dir.root.join("hosts"))
        .into_iter()
        .flatten()
        .flatten()
    {
        let Ok(entries) = std::fs::read_dir(host.path().join("logs")) else {
            continue;
        };
        files.extend(entries.flatten().map(|e| e.path()).filter_map(|p| {
            let (format, process) = log_file(&p)?;
            (format == Format::Csv).then_some((p, format, process))
        }));
    }
    files.sort_by(|a, b| a.0.cmp(&b.0));

    let mission = Mission::load(&dir.mission()).ok();
    let remote = remote_vehicles(dir, mission.as_ref());
    // The command of tick `ticks` only tells the agents the mission is over: not a message
    // of the mission's links.
    let last_tick = mission.as_ref().map_or(u64::MAX, |m| m.ticks());

    let silent = mission.as_ref().map_or_else(Vec::new, |m| {
        vbap_mission::faults::FaultPlan::new(m)
            .kills
            .iter()
            .map(|k| (k.vehicle, k.tick, k.restart.unwrap_or(u64::MAX)))
            .collect()
    });
    let parts = read_logs(&files, last_tick, &remote, silent)?;

    let nominal_ms = mission.as_ref().and_then(|m| match m.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(m.mission.dt / f * 1e3),
    });
    let mut report = Report {
        pace: mission
            .as_ref()
            .map_or("unknown".into(), |m| m.mission.pace.to_string()),
        ..Report::default()
    };
    let mut dists = Distributions::default();
    let mut hops: BTreeMap<String, HopAcc> = BTreeMap::new();
    let mut published: Vec<(u64, u64, u64)> = Vec::new();
    // The last state of each tick in, ns.
    let mut last_state: BTreeMap<u64, u64> = BTreeMap::new();
    // Body receptions per process (a process may have records in both formats).
    let mut received: BTreeMap<&str, Vec<(u64, u64)>> = BTreeMap::new();
    for (i, part) in parts {
        report.records += part.records;
        report.unparsed += part.unparsed;
        for (hop, acc) in part.hops {
            hops.entry(hop).or_default().merge(acc);
        }
        published.extend(part.body_sent.into_iter().filter(|p| p.1 < last_tick));
        for (tick, recv) in part.state_recv {
            let t = last_state.entry(tick).or_insert(recv);
            *t = (*t).max(recv);
        }
        let recv = received.entry(files[i].2.as_str()).or_default();
        recv.extend(part.body_recv.into_iter().filter(|p| p.0 < last_tick));
    }
    for (process, mut recv) in received {
        if !recv.is_empty() {
            recv.sort_by_key(|&(_, t)| t);
            dists.periods.insert(process.to_string(), periods(&recv));
        }
    }
    // The coordinator's publications: every agent saw the same (seq, sent_ns).
    published.sort_unstable();
    published.dedup_by_key(|p| p.0);
    if nominal_ms.is_none() {
        report.tick = tick_report(&published, &last_state);
    }
    if published.len() > 1 {
        let mut times: Vec<(u64, u64)> = published.iter().map(|&(_, k, t)| (k, t)).collect();
        times.sort_by_key(|&(_, t)| t);
        dists
            .periods
            .insert("coordinator".to_string(), periods(&times));
    }

    hop_reports(hops, &mut report, &mut dists);
    loop_reports(nominal_ms, &mut report, &mut dists);
    if let Ok(s) = Summary::read(dir) {
        report.late_ticks = s.late_ticks;
    }
    Ok((report, dists))
}

/// Periods (ms) between consecutive times (ns), each tagged with the later tick.
fn periods(times: &[(u64, u64)]) -> Vec<(u64, f64)> {
    times
        .windows(2)
        .map(|w| (w[1].0, (w[1].1 as i128 - w[0].1 as i128) as f64 / 1e6))
        .collect()
}

/// The per-hop figures and distributions from the merged accumulators.
fn hop_reports(hops: BTreeMap<String, HopAcc>, report: &mut Report, dists: &mut Distributions) {
    for (hop, mut acc) in hops {
        // Commands whose fate was drawn but never read (a killed process) were sent to
        // a live vehicle all the same: counted received, as the simulator counts them.
        let received = acc.transport_us.len() as u64 + acc.unread;
        // Two ways of logging the link model: reception records that carry the injected
        // delay (every record is a delivery), or receptions logged on arrival over IPC, the
        // link model deciding afterwards (separate "held" and "drop" records): then the
        // deliveries are the receptions not dropped, and those delivered without a
        // "held" record were delivered at once (0 ms).
        let held = acc.held_ms.len() as u64;
        let (delivered, mut injected) = if acc.inline_ms.is_empty() {
            let delivered = received.saturating_sub(acc.dropped_injected + acc.superseded);
            let mut v = std::mem::take(&mut acc.held_ms);
            let at_once = (delivered as usize).saturating_sub(v.len());
            v.extend(std::iter::repeat_n(0.0, at_once));
            (delivered, v)
        } else {
            (received, std::mem::take(&mut acc.inline_ms))
        };
        let transport = Percentiles::of(&mut acc.transport_us);
        report.hops.insert(
            hop.clone(),
            HopReport {
                transport_us: transport,
                injected_ms: Percentiles::of(&mut injected),
                delivered,
                dropped_injected: acc.dropped_injected,
                superseded: acc.superseded,
                dropped_overflow: acc.dropped_overflow,
                received,
                bytes_mean: (acc.sized > 0).then(|| acc.bytes as f64 / acc.sized as f64),
                bytes_max: (acc.sized > 0).then_some(acc.bytes_max),
                bytes_total: (acc.sized > 0).then_some(acc.bytes),
                held,
                reasons: std::mem::take(&mut acc.reasons),
            },
        );
        dists.transport_us.insert(hop.clone(), acc.transport_us);
        dists.injected_ms.insert(hop, injected);
    }
}

/// The loop periods and jitter of each process against `nominal_ms` (the pace's tick
/// period; in lockstep, the median period).
fn loop_reports(nominal_ms: Option<f64>, report: &mut Report, dists: &mut Distributions) {
    for (process, p) in &dists.periods {
        let mut values: Vec<f64> = p.iter().map(|&(_, v)| v).collect();
        let period = Percentiles::of(&mut values);
        let nominal = nominal_ms.unwrap_or(period.p50);
        let mut jitter: Vec<f64> = p.iter().map(|&(_, v)| (v - nominal).abs()).collect();
        let jitter_p = Percentiles::of(&mut jitter);
        report.loops.insert(
            process.clone(),
            LoopReport {
                period_ms: period,
                jitter_ms: jitter_p,
                nominal_ms: nominal,
                iterations: p.len() as u64 + 1,
            },
        );
        dists.jitter_ms.insert(process.clone(), jitter);
    }
}

/// The tick breakdown of a lockstep run ([`TickReport`]) from the publications (seq, tick,
/// sent_ns) and the last state of each tick in; None with fewer than 10 ticks.
fn tick_report(
    published: &[(u64, u64, u64)],
    last_state: &BTreeMap<u64, u64>,
) -> Option<TickReport> {
    let sent: BTreeMap<u64, u64> = published.iter().map(|&(_, k, t)| (k, t)).collect();
    let us = |a: u64, b: u64| (b as i128 - a as i128) as f64 / 1e3;
    let (mut period, mut waiting, mut after) = (Vec::new(), Vec::new(), Vec::new());
    for (&k, &now) in sent.iter().skip(1) {
        let (Some(&before), Some(&last)) = (sent.get(&(k - 1)), last_state.get(&k)) else {
            continue;
        };
        period.push(us(before, now));
        waiting.push(us(before, last).max(0.0));
        after.push(us(last.max(before), now));
    }
    (period.len() >= 10).then(|| TickReport {
        ticks: period.len() as u64,
        period_us: Percentiles::of(&mut period),
        waiting_for_states_us: Percentiles::of(&mut waiting),
        after_last_state_us: Percentiles::of(&mut after),
    })
}

/// The vehicles placed on another host than the coordinator's, by the run's `hosts.toml`
/// (a run over hosts); none for a one-host run.
fn remote_vehicles(dir: &RunDir, mission: Option<&Mission>) -> std::collections::BTreeSet<u32> {
    let (Some(m), Ok(text)) = (
        mission,
        std::fs::read_to_string(dir.root.join("hosts.toml")),
    ) else {
        return Default::default();
    };
    let Ok(hosts) = vbap_mission::hosts::Hosts::parse(&text, "hosts.toml", m.vehicles.count) else {
        return Default::default();
    };
    (0..m.vehicles.count as u32)
        .filter(|&v| hosts.host_of(v) != Some(hosts.shore.as_str()))
        .collect()
}
