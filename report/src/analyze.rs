//! `vbap analyze RUN_DIR`: timing analysis of a run from its message records.
//!
//! Every receiver records each message it receives over IPC (event `recv`) in
//! `logs/<process>.msgs.csv` ([`vbap_ipc::msglog`], the format and its units), with the
//! sender's wall-clock send time `sent_ns` and its own receive time `recv_ns` (all
//! processes share one host clock): their difference is the hop's *transport* latency. The
//! link model (docs/ARCHITECTURE.md §6) works in mission time after reception and records its verdicts
//! separately: `held` (with `injected_ns`, the delay it added) and `drop` (with `reason`:
//! `"loss"`, `"burst"`, `"link_down"`, … are counted as *injected* drops, `"overflow"` as
//! queue overflow). A hop's deliveries are then its receptions minus its injected drops,
//! and the deliveries without a `held` record were delivered at once (0 ms).
//!
//! Run directories of earlier versions carry the same records as JSON lines of target
//! `vbap::msg` in `logs/<process>.jsonl` (message `"recv"`, `"held"` with hop `<hop>_link`
//! and `injected_ms`, `"drop"`); they are read too, into the same figures, and a process
//! may have records in both files. JSON reception records that carry `injected_ms`
//! themselves are read as well: then every reception is a delivery and the transport
//! latency is `recv_ns − sent_ns − injected`.
//!
//! Loops: an agent's loop is driven by the body commands it receives, so its period is the
//! time between consecutive body receptions; the coordinator's period is the time between
//! consecutive body publications (their `sent_ns`, read from the agents' records). Jitter
//! is |period − nominal|, the nominal period being dt / pace factor in real-time runs and
//! the median period in lockstep runs (as fast as possible: no nominal period). The field
//! server answers requests and has no loop of its own.
//!
//! Logs of big fleets run to millions of lines: files are streamed and read in parallel;
//! CSV lines are split in place, and of the JSON logs only lines containing the target
//! string are parsed (with a borrowed, typed deserializer, not a generic JSON tree).
//!
//! Lockstep ticks: from the coordinator's publications and the states it received, the
//! time of each tick split into waiting for the agents' states and the coordinator's own
//! work after the last one ([`TickReport`]).
//!
//! [`analyze`] also writes `latency.svg` (per-hop distributions) and `loops.svg` (loop
//! period over the run and jitter distributions) into the run directory.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use vbap_ipc::msglog::{self, MsgEvent, MSG_HEADER, MSG_SUFFIX};
use vbap_ipc::telemetry::MSG_TARGET;
use vbap_mission::config::{Mission, Pace};
use vbap_mission::rundir::{Percentiles, RunDir, Summary};

pub mod plots;

/// Seconds since the Unix epoch of an RFC 3339 UTC timestamp as the tracing logs write it
/// (`2026-12-01T17:24:09.458255Z`); None when it is not one.
pub fn parse_utc(ts: &str) -> Option<f64> {
    if !ts.ends_with('Z') {
        return None;
    }
    let t = time::OffsetDateTime::parse(ts, &time::format_description::well_known::Rfc3339).ok()?;
    Some(t.unix_timestamp() as f64 + f64::from(t.nanosecond()) * 1e-9)
}

/// File name of the latency plot.
pub const LATENCY_SVG: &str = "latency.svg";
/// File name of the loop plot.
pub const LOOPS_SVG: &str = "loops.svg";

/// Figures of one hop (docs/ARCHITECTURE.md §9, `vbap analyze --json`).
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
    /// Messages lost to a full queue.
    pub dropped_overflow: u64,
    /// Messages received over IPC (the link model may drop some of them after).
    pub received: u64,
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
    /// Per-hop transport percentiles for `summary.json`'s `latency_us`.
    pub fn latency_summary(&self) -> BTreeMap<String, Percentiles> {
        self.hops
            .iter()
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
        s.messages.dropped_overflow = self.hops.values().map(|h| h.dropped_overflow).sum();
    }

    /// The human-readable report of `vbap analyze`.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        // An injected delay (ms of mission time) in the unit of its size: "250 ms", "45 min".
        let delay = |ms: f64| {
            if ms == 0.0 {
                "0".to_string()
            } else {
                crate::plot::style::fmt_duration(ms * 1e-3)
            }
        };
        let mut out = String::new();
        let _ = writeln!(out, "pace: {}, {} message records", self.pace, self.records);
        let _ = writeln!(
            out,
            "\n{:<14} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9}",
            "hop",
            "delivered",
            "dropped",
            "overflow",
            "p50 µs",
            "p90 µs",
            "p99 µs",
            "max µs",
            "inj p50",
            "inj p99",
            "inj max"
        );
        for (hop, h) in &self.hops {
            let p = h.transport_us;
            let q = h.injected_ms;
            let _ = writeln!(
                out,
                "{hop:<14} {:>9} {:>9} {:>9} │ {:>9.1} {:>9.1} {:>9.1} {:>9.1} │ {:>9} {:>9} {:>9}",
                h.delivered,
                h.dropped_injected,
                h.dropped_overflow,
                p.p50,
                p.p90,
                p.p99,
                p.max,
                delay(q.p50),
                delay(q.p99),
                delay(q.max)
            );
        }
        let _ = writeln!(
            out,
            "(transport latency = receive − send − injected link delay; dropped = by the link model)"
        );
        let _ = writeln!(
            out,
            "\n{:<28} {:>7} {:>9} │ {:>9} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9}",
            "loop",
            "iters",
            "nominal",
            "p50 ms",
            "p90 ms",
            "p99 ms",
            "max ms",
            "jit p50",
            "jit p99",
            "jit max"
        );
        let line = |out: &mut String, name: &str, l: &LoopReport| {
            let p = l.period_ms;
            let j = l.jitter_ms;
            let _ = writeln!(
                out,
                "{name:<28} {:>7} {:>9.3} │ {:>9.3} {:>9.3} {:>9.3} {:>9.3} │ {:>9.3} {:>9.3} {:>9.3}",
                l.iterations, l.nominal_ms, p.p50, p.p90, p.p99, p.max, j.p50, j.p99, j.max
            );
        };
        let agents: Vec<(&String, &LoopReport)> = self
            .loops
            .iter()
            .filter(|(k, _)| k.starts_with("vehicle_agent"))
            .collect();
        for (name, l) in &self.loops {
            if !name.starts_with("vehicle_agent") || agents.len() <= 8 {
                line(&mut out, name, l);
            }
        }
        if agents.len() > 8 {
            // Many agents: the median one and the worst one (by p99 jitter).
            let mut by_jitter = agents.clone();
            by_jitter.sort_by(|a, b| a.1.jitter_ms.p99.total_cmp(&b.1.jitter_ms.p99));
            let (mname, median) = by_jitter[by_jitter.len() / 2];
            let (wname, worst) = by_jitter[by_jitter.len() - 1];
            line(&mut out, &format!("{mname} (median)"), median);
            line(&mut out, &format!("{wname} (worst)"), worst);
            let _ = writeln!(out, "({} agents; all of them in --json)", agents.len());
        }
        if let Some(t) = &self.tick {
            let _ = writeln!(
                out,
                "\n{:<28} {:>9} {:>9} {:>9} {:>9}   ({} lockstep ticks)",
                "tick", "p50 µs", "p90 µs", "p99 µs", "max µs", t.ticks
            );
            for (name, p) in [
                ("period", t.period_us),
                ("waiting for states", t.waiting_for_states_us),
                ("after the last state", t.after_last_state_us),
            ] {
                let _ = writeln!(
                    out,
                    "{name:<28} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
                    p.p50, p.p90, p.p99, p.max
                );
            }
        }
        let _ = writeln!(out, "\nlate ticks: {}", self.late_ticks);
        out
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

/// `vbap analyze RUN_DIR [--json]`: prints the report and writes the plots; returns the
/// exit code. A directory without message records is invalid input (exit 2): the message
/// says what is missing, and no empty table or plot is written.
pub fn main(run_dir: &Path, json: bool) -> Result<i32> {
    let invalid = |why: String| -> anyhow::Error {
        crate::InvalidRunDir(format!("{}: {why}", run_dir.display())).into()
    };
    let logs = run_dir.join("logs");
    if !logs.is_dir() {
        if !run_dir.join("mission.toml").is_file() {
            return Err(invalid(
                "not a run directory (no mission.toml, no logs/)".into(),
            ));
        }
        return Err(invalid(format!(
            "no message records to analyse: {} does not exist ({NO_RECORDS_HINT})",
            logs.display()
        )));
    }
    let dir = RunDir {
        root: run_dir.to_path_buf(),
    };
    let (report, dists) = compute(&dir)?;
    if report.records == 0 {
        let unparsed = if report.unparsed > 0 {
            format!("; {} record lines could not be parsed", report.unparsed)
        } else {
            String::new()
        };
        return Err(invalid(format!(
            "no message records to analyse: no logs/*{MSG_SUFFIX} with records and no `{MSG_TARGET}` records in logs/*.jsonl{unparsed} ({NO_RECORDS_HINT})"
        )));
    }
    if let Err(e) = plots::write_plots(&dir, &report, &dists) {
        tracing::warn!(error = %format!("{e:#}"), "writing the analysis plots");
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.to_text());
        eprintln!(
            "plots: {}, {}",
            dir.root.join(LATENCY_SVG).display(),
            dir.root.join(LOOPS_SVG).display()
        );
    }
    Ok(vbap_ipc::process::EXIT_OK)
}

/// Why a run directory may hold no message records.
const NO_RECORDS_HINT: &str = "`vbap sim` runs in one process and records no messages; \
`vbap run` records them unless RUST_LOG turned them off";

/// Reads the logs of `dir` and computes the report (the plots are drawn by
/// [`crate::draw_run`] or [`plots::write_plots`]).
pub fn analyze(dir: &RunDir) -> Result<Report> {
    Ok(compute(dir)?.0)
}

/// One log line of the message target, borrowed from the line.
#[derive(Deserialize)]
struct Line<'a> {
    #[serde(borrow)]
    target: Cow<'a, str>,
    #[serde(borrow, default)]
    fields: Fields<'a>,
}

#[derive(Deserialize, Default)]
struct Fields<'a> {
    #[serde(borrow, default)]
    message: Option<Cow<'a, str>>,
    #[serde(borrow, default)]
    hop: Option<Cow<'a, str>>,
    #[serde(default)]
    tick: Option<u64>,
    #[serde(default)]
    seq: Option<u64>,
    #[serde(default)]
    sent_ns: Option<u64>,
    #[serde(default)]
    recv_ns: Option<u64>,
    #[serde(default)]
    injected_ms: Option<f64>,
    #[serde(borrow, default)]
    reason: Option<Cow<'a, str>>,
}

/// What one log file contributes.
#[derive(Default)]
struct Partial {
    /// Commands of this tick and later only end the mission (not counted).
    last_tick: u64,
    hops: BTreeMap<String, HopAcc>,
    /// (tick, recv_ns) of the body commands this process received.
    body_recv: Vec<(u64, u64)>,
    /// (seq, tick, sent_ns) of the body commands received (the coordinator's publications).
    body_sent: Vec<(u64, u64, u64)>,
    /// (tick, recv_ns) of the states the coordinator received.
    state_recv: Vec<(u64, u64)>,
    records: u64,
    unparsed: u64,
}

#[derive(Default)]
struct HopAcc {
    transport_us: Vec<f64>,
    /// Injected delays carried by the reception records themselves.
    inline_ms: Vec<f64>,
    /// Injected delays of `"held"` records (messages the link model delayed).
    held_ms: Vec<f64>,
    dropped_injected: u64,
    dropped_overflow: u64,
}

impl HopAcc {
    fn merge(&mut self, other: HopAcc) {
        self.transport_us.extend(other.transport_us);
        self.inline_ms.extend(other.inline_ms);
        self.held_ms.extend(other.held_ms);
        self.dropped_injected += other.dropped_injected;
        self.dropped_overflow += other.dropped_overflow;
    }
}

/// One message record, from either format, the hop named plainly (no `_link`).
struct Rec<'a> {
    event: MsgEvent,
    hop: &'a str,
    tick: Option<u64>,
    seq: Option<u64>,
    sent_ns: Option<u64>,
    recv_ns: Option<u64>,
    /// The injected delay, ms of mission time (`held` records, or old reception records
    /// that carry it).
    injected_ms: Option<f64>,
    reason: Option<&'a str>,
}

impl Partial {
    /// Adds one record of a process (`is_agent`: a vehicle agent's).
    fn add(&mut self, r: Rec<'_>, is_agent: bool) {
        self.records += 1;
        if r.hop == "body" && r.tick.is_some_and(|t| t >= self.last_tick) {
            return; // "the mission is over": not a command of the mission's links
        }
        let acc = match self.hops.get_mut(r.hop) {
            Some(a) => a,
            None => self.hops.entry(r.hop.to_string()).or_default(),
        };
        match r.event {
            // Dropped: by a full queue, or by the link model (loss, burst, link_down).
            MsgEvent::Drop => match r.reason {
                Some("overflow") => acc.dropped_overflow += 1,
                _ => acc.dropped_injected += 1,
            },
            // Held by the link model for `injected_ms` (mission time) before delivery.
            MsgEvent::Held => {
                if let Some(v) = r.injected_ms.filter(|v| v.is_finite()) {
                    acc.held_ms.push(v);
                }
            }
            MsgEvent::Recv => {
                let (Some(sent), Some(recv)) = (r.sent_ns, r.recv_ns) else {
                    self.unparsed += 1;
                    return;
                };
                let injected_ms = r.injected_ms.filter(|v| v.is_finite()).unwrap_or(0.0);
                // Integer difference first: the timestamps (~1.8e18 ns) do not fit f64's
                // 53-bit mantissa.
                let wire_ns = recv as i128 - sent as i128;
                acc.transport_us
                    .push(wire_ns as f64 / 1e3 - injected_ms * 1e3);
                if r.injected_ms.is_some() {
                    acc.inline_ms.push(injected_ms);
                }
                if is_agent && r.hop == "body" {
                    let tick = r.tick.unwrap_or(0);
                    self.body_recv.push((tick, recv));
                    self.body_sent.push((r.seq.unwrap_or(0), tick, sent));
                }
                if r.hop == "state" {
                    if let Some(tick) = r.tick {
                        self.state_recv.push((tick, recv));
                    }
                }
            }
        }
    }
}

/// The format of a log file.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    /// `<process>.jsonl`: tracing JSON lines, message records among them (earlier versions).
    Json,
    /// `<process>.msgs.csv`: message records only ([`vbap_ipc::msglog`]).
    Csv,
}

/// A log file of `logs/`: its format and process, or None for any other file.
fn log_file(path: &Path) -> Option<(Format, String)> {
    let name = path.file_name()?.to_str()?;
    if let Some(process) = name.strip_suffix(MSG_SUFFIX) {
        Some((Format::Csv, process.to_string()))
    } else {
        name.strip_suffix(".jsonl")
            .map(|process| (Format::Json, process.to_string()))
    }
}

/// Parses one log file.
fn read_log(path: &Path, format: Format, is_agent: bool, last_tick: u64) -> Result<Partial> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 18, file);
    let mut part = Partial {
        last_tick,
        ..Partial::default()
    };
    let mut buf = Vec::with_capacity(512);
    loop {
        buf.clear();
        let n = reader
            .read_until(b'\n', &mut buf)
            .with_context(|| format!("reading {}", path.display()))?;
        if n == 0 {
            break;
        }
        let Ok(text) = std::str::from_utf8(&buf) else {
            part.unparsed += u64::from(format == Format::Csv);
            continue;
        };
        match format {
            Format::Csv => read_csv_line(text, &mut part, is_agent),
            Format::Json => read_json_line(text, &mut part, is_agent),
        }
    }
    Ok(part)
}

/// One line of a `.msgs.csv` file.
fn read_csv_line(text: &str, part: &mut Partial, is_agent: bool) {
    let Some(r) = msglog::parse(text) else {
        let line = text.trim_end();
        if !line.is_empty() && line != MSG_HEADER {
            part.unparsed += 1;
        }
        return;
    };
    part.add(
        Rec {
            event: r.event,
            hop: r.hop,
            tick: Some(r.tick),
            seq: r.seq,
            sent_ns: r.sent_ns,
            recv_ns: r.recv_ns,
            injected_ms: r.injected_ns.map(|ns| ns as f64 / 1e6),
            reason: r.reason,
        },
        is_agent,
    );
}

/// One line of a `.jsonl` file (records of earlier versions, target `vbap::msg`).
fn read_json_line(text: &str, part: &mut Partial, is_agent: bool) {
    // Cheap filter first: most lines of a big log are records, but not all lines are.
    if !text.contains(MSG_TARGET) {
        return;
    }
    let Ok(line) = serde_json::from_str::<Line<'_>>(text) else {
        part.unparsed += 1;
        return;
    };
    if line.target != MSG_TARGET {
        return;
    }
    let f = line.fields;
    let Some(hop) = f.hop else {
        part.unparsed += 1;
        return;
    };
    let event = match f.message.as_deref() {
        Some("drop") => MsgEvent::Drop,
        Some("held") => MsgEvent::Held,
        _ => MsgEvent::Recv,
    };
    part.add(
        Rec {
            event,
            // The link model's records name the hop `<hop>_link`.
            hop: hop.strip_suffix("_link").unwrap_or(&hop),
            tick: f.tick,
            seq: f.seq,
            sent_ns: f.sent_ns,
            recv_ns: f.recv_ns,
            injected_ms: f.injected_ms,
            reason: f.reason.as_deref(),
        },
        is_agent,
    );
}

/// Periods (ms) between consecutive times (ns), each tagged with the later tick.
fn periods(times: &[(u64, u64)]) -> Vec<(u64, f64)> {
    times
        .windows(2)
        .map(|w| (w[1].0, (w[1].1 as i128 - w[0].1 as i128) as f64 / 1e6))
        .collect()
}

/// Reads the logs of `dir` and computes the report and the distributions behind it.
pub fn compute(dir: &RunDir) -> Result<(Report, Distributions)> {
    let logs = dir.root.join("logs");
    let mut files: Vec<(PathBuf, Format, String)> = std::fs::read_dir(&logs)
        .with_context(|| format!("reading {}", logs.display()))?
        .flatten()
        .map(|e| e.path())
        .filter_map(|p| log_file(&p).map(|(format, process)| (p, format, process)))
        .collect();
    files.sort_by(|a, b| a.0.cmp(&b.0));

    let mission = Mission::load(&dir.mission()).ok();
    // The command of tick `ticks` only tells the agents the mission is over: not a message
    // of the mission's links.
    let last_tick = mission.as_ref().map_or(u64::MAX, |m| m.ticks());

    let parts = read_logs(&files, last_tick)?;

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

/// The message records of `files` (path, format, process) parsed in parallel, one worker per
/// core, in the order of `files`.
fn read_logs(files: &[(PathBuf, Format, String)], last_tick: u64) -> Result<Vec<(usize, Partial)>> {
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(files.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut parts: Vec<(usize, Partial)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                scope.spawn(|| -> Result<Vec<(usize, Partial)>> {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some((path, format, process)) = files.get(i) else {
                            break;
                        };
                        let is_agent = process.starts_with("vehicle_agent");
                        mine.push((i, read_log(path, *format, is_agent, last_tick)?));
                    }
                    Ok(mine)
                })
            })
            .collect();
        let mut all = Vec::new();
        for h in handles {
            all.extend(h.join().expect("a log reader panicked")?);
        }
        Ok::<_, anyhow::Error>(all)
    })?;
    parts.sort_by_key(|(i, _)| *i);
    Ok(parts)
}

/// The per-hop figures and distributions from the merged accumulators.
fn hop_reports(hops: BTreeMap<String, HopAcc>, report: &mut Report, dists: &mut Distributions) {
    for (hop, mut acc) in hops {
        let received = acc.transport_us.len() as u64;
        // Two ways of logging the link model: reception records that carry the injected
        // delay (every record is a delivery), or receptions logged on arrival over IPC, the
        // link model deciding afterwards (separate "held" and "drop" records): then the
        // deliveries are the receptions not dropped, and those delivered without a
        // "held" record were delivered at once (0 ms).
        let (delivered, mut injected) = if acc.inline_ms.is_empty() {
            let delivered = received.saturating_sub(acc.dropped_injected);
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
                dropped_overflow: acc.dropped_overflow,
                received,
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

#[cfg(test)]
mod tests {
    use super::plots::{ccdf_points, cdf_points};
    use super::*;

    #[test]
    fn utc_timestamps_parse() {
        assert_eq!(parse_utc("1970-01-01T00:00:00Z"), Some(0.0));
        let t = parse_utc("2026-12-01T17:24:09.458255Z").unwrap();
        // 2026-12-01 is day 20788 since the epoch.
        assert!((t - (20_788.0 * 86_400.0 + 17.0 * 3600.0 + 24.0 * 60.0 + 9.458255)).abs() < 1e-6);
        assert_eq!(parse_utc("2000-03-01T00:00:01.5Z"), Some(951_868_801.5));
        assert_eq!(parse_utc("2024-02-29T23:59:59Z"), Some(1_709_251_199.0));
        assert_eq!(parse_utc("2024-02-29 23:59:59"), None);
        assert_eq!(parse_utc("not a time"), None);
        assert_eq!(parse_utc("2026-13-01T00:00:00Z"), None);
    }

    /// The state hop of the records both test logs hold: 3 received, 1 lost by the link, 1
    /// held 50 ms, 1 delivered at once; plus the overflow drop of the agent's log.
    fn assert_state_hop(r: &Report) {
        let state = &r.hops["state"];
        assert_eq!(
            (
                state.received,
                state.delivered,
                state.dropped_injected,
                state.dropped_overflow
            ),
            (3, 2, 1, 1)
        );
        assert_eq!((state.injected_ms.p50, state.injected_ms.max), (0.0, 50.0));
        assert_eq!(state.transport_us.max, 7.0);
    }

    fn write_logs(dir: &Path) {
        std::fs::create_dir_all(dir.join("logs")).unwrap();
        let t0: u64 = 1_795_437_897_283_832_923;
        let mut agent = String::new();
        agent.push_str("{\"timestamp\":\"x\",\"level\":\"INFO\",\"fields\":{\"message\":\"agent up\"},\"target\":\"vehicle_agent::run\"}\n");
        for k in 0..5u64 {
            let sent = t0 + k * 1_000_000;
            let recv = sent + 20_000 + 5_000_000 * u64::from(k == 3);
            let inj = if k == 3 { ",\"injected_ms\":5.0" } else { "" };
            agent.push_str(&format!(
                "{{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{{\"message\":\"recv\",\"hop\":\"body\",\"sender\":4294967294,\"receiver\":0,\"tick\":{k},\"seq\":{},\"sent_ns\":{sent},\"recv_ns\":{recv}{inj}}},\"target\":\"vbap::msg\"}}\n",
                k + 1
            ));
        }
        agent.push_str("{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{\"message\":\"drop\",\"hop\":\"body\",\"reason\":\"injected\",\"tick\":6},\"target\":\"vbap::msg\"}\n");
        agent.push_str("{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{\"message\":\"drop\",\"hop\":\"state\",\"reason\":\"overflow\",\"tick\":6},\"target\":\"vbap::msg\"}\n");
        agent.push_str("not json vbap::msg\n");
        std::fs::write(dir.join("logs/vehicle_agent_0.jsonl"), agent).unwrap();
        // The coordinator's format: receptions on arrival, then the link model's verdict.
        let mut coord = String::new();
        for k in 0..3u64 {
            coord.push_str(&format!(
                "{{\"fields\":{{\"message\":\"recv\",\"hop\":\"state\",\"sender\":0,\"tick\":{k},\"seq\":{k},\"sent_ns\":{},\"recv_ns\":{}}},\"target\":\"vbap::msg\"}}\n",
                t0 + k,
                t0 + k + 7_000
            ));
        }
        coord.push_str("{\"fields\":{\"message\":\"held\",\"hop\":\"state_link\",\"sender\":0,\"tick\":0,\"injected_ms\":50.0},\"target\":\"vbap::msg\"}\n");
        coord.push_str("{\"fields\":{\"message\":\"drop\",\"hop\":\"state\",\"sender\":0,\"tick\":1,\"reason\":\"loss\"},\"target\":\"vbap::msg\"}\n");
        std::fs::write(dir.join("logs/coordinator.jsonl"), coord).unwrap();
    }

    #[test]
    fn latency_drops_and_loops_from_logs() {
        let root = std::env::temp_dir().join(format!("vbap-analyze-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        write_logs(&root);
        let dir = RunDir { root: root.clone() };
        let (r, d) = compute(&dir).unwrap();
        let body = &r.hops["body"];
        assert_eq!(body.delivered, 5);
        assert_eq!(body.dropped_injected, 1);
        assert_state_hop(&r);
        assert!(!r.hops.contains_key("state_link"));
        // 20 µs each, exactly (integer subtraction), the injected 5 ms taken out.
        assert!(d.transport_us["body"]
            .iter()
            .all(|&v| (v - 20.0).abs() < 1e-9));
        assert_eq!(body.injected_ms.max, 5.0);
        assert_eq!(r.unparsed, 1);
        // Publications every 1 ms; receptions too, except around the delayed one.
        let c = &r.loops["coordinator"];
        assert_eq!(c.period_ms.p50, 1.0);
        assert_eq!(c.jitter_ms.max, 0.0);
        let a = &r.loops["vehicle_agent_0"];
        assert_eq!(a.iterations, 5);
        // Receptions at 0, 1, 2, 4 and 8 ms (+ 20 µs): the delayed tick 3 came last.
        assert_eq!(a.period_ms.max, 4.0);
        let mut s = Summary::default();
        r.fill_summary(&mut s);
        assert_eq!(s.messages.dropped_injected, 2);
        assert_eq!(s.messages.dropped_overflow, 1);
        assert_eq!(s.latency_us["body"].p50, 20.0);
        let (r, d) = compute(&dir).unwrap();
        plots::write_plots(&dir, &r, &d).unwrap();
        assert!(root.join(LATENCY_SVG).is_file());
        assert!(root.join(LOOPS_SVG).is_file());
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn latency_drops_and_loops_from_csv_records() {
        use vbap_ipc::msglog::MsgLog;
        let root = std::env::temp_dir().join(format!("vbap-analyze-csv-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("logs")).unwrap();
        let dir = RunDir { root: root.clone() };
        // The tracing logs now carry lifecycle lines only.
        std::fs::write(
            dir.log("vehicle_agent_0"),
            "{\"timestamp\":\"x\",\"level\":\"INFO\",\"fields\":{\"message\":\"agent up\"},\"target\":\"vehicle_agent::run\"}\n",
        )
        .unwrap();
        let t0: u64 = 1_795_437_897_283_832_923;
        const COORD: u32 = u32::MAX - 1;
        {
            // Receptions on arrival over IPC, then the link model's verdicts.
            let mut agent = MsgLog::open(&dir.msg_log("vehicle_agent_0")).unwrap();
            for k in 0..6u64 {
                let sent = t0 + k * 1_000_000;
                agent.recv("body", COORD, 0, k, k + 1, sent, sent + 20_000);
            }
            agent.held("body", COORD, 0, 3, 0.005);
            agent.drop("body", COORD, 0, 5, "loss");
            agent.drop("state", 0, COORD, 6, "overflow");
            let mut coord = MsgLog::open(&dir.msg_log("coordinator")).unwrap();
            for k in 0..3u64 {
                coord.recv("state", 0, COORD, k, k, t0 + k, t0 + k + 7_000);
            }
            coord.held("state", 0, COORD, 0, 0.05);
            coord.drop("state", 0, COORD, 1, "loss");
        }
        let mut csv = std::fs::read_to_string(dir.msg_log("vehicle_agent_0")).unwrap();
        csv.push_str("recv,body,1,2\n");
        std::fs::write(dir.msg_log("vehicle_agent_0"), csv).unwrap();

        let (r, d) = compute(&dir).unwrap();
        assert_eq!((r.records, r.unparsed), (14, 1));
        let body = &r.hops["body"];
        assert_eq!(
            (body.received, body.delivered, body.dropped_injected),
            (6, 5, 1)
        );
        assert_eq!((body.injected_ms.p50, body.injected_ms.max), (0.0, 5.0));
        assert!(d.transport_us["body"]
            .iter()
            .all(|&v| (v - 20.0).abs() < 1e-9));
        // The same figures as from the JSON records of `write_logs`.
        assert_state_hop(&r);
        assert_eq!(r.loops["coordinator"].period_ms.p50, 1.0);
        let a = &r.loops["vehicle_agent_0"];
        assert_eq!((a.iterations, a.period_ms.max), (6, 1.0));
        let mut s = Summary::default();
        r.fill_summary(&mut s);
        assert_eq!(s.messages.dropped_injected, 2);
        assert_eq!(s.messages.dropped_overflow, 1);
        assert_eq!(s.latency_us["body"].p50, 20.0);
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_process_may_have_records_in_both_formats() {
        let root = std::env::temp_dir().join(format!("vbap-analyze-mixed-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("logs")).unwrap();
        let dir = RunDir { root: root.clone() };
        let t0: u64 = 1_795_437_897_283_832_923;
        let mut json = String::new();
        for k in 0..3u64 {
            let sent = t0 + k * 1_000_000;
            json.push_str(&format!(
                "{{\"fields\":{{\"message\":\"recv\",\"hop\":\"body\",\"sender\":4294967294,\"receiver\":0,\"tick\":{k},\"seq\":{k},\"sent_ns\":{sent},\"recv_ns\":{}}},\"target\":\"vbap::msg\"}}\n",
                sent + 10_000
            ));
        }
        std::fs::write(dir.log("vehicle_agent_0"), json).unwrap();
        let mut log = vbap_ipc::msglog::MsgLog::open(&dir.msg_log("vehicle_agent_0")).unwrap();
        for k in 3..6u64 {
            let sent = t0 + k * 1_000_000;
            log.recv("body", u32::MAX - 1, 0, k, k, sent, sent + 10_000);
        }
        drop(log);
        let (r, _) = compute(&dir).unwrap();
        assert_eq!(r.hops["body"].received, 6);
        let a = &r.loops["vehicle_agent_0"];
        assert_eq!((a.iterations, a.period_ms.max), (6, 1.0));
        assert_eq!(r.loops["coordinator"].iterations, 6);
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn cdf_keeps_the_tail() {
        let v: Vec<f64> = (1..=10_000).map(f64::from).collect();
        let c = cdf_points(&v, 400);
        assert!(c.len() <= 420, "{}", c.len());
        assert_eq!(c.last(), Some(&(10_000.0, 1.0)));
        assert_eq!(c[0], (1.0, 1e-4));
        assert!(c.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 < w[1].1));
        let cc = ccdf_points(&v, 400);
        let (v, f) = *cc.last().unwrap();
        assert_eq!(v, 9_999.0);
        assert!((f - 1e-4).abs() < 1e-12);
    }
}
