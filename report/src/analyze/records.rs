//! Reading the message records of `logs/`: the CSV records (`<process>.msgs.csv`) and the
//! JSON lines of earlier versions (`<process>.jsonl`, target `vbap::msg`), each file into
//! what it contributes ([`Partial`]), the files in parallel.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::io::BufRead;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Deserialize;
use vbap_wire::msglog::MSG_TARGET;

/// The hop of acoustic frames (agent to agent; `vehicle_agent::run::modem::HOP`).
pub(super) const ACOUSTIC: &str = "acoustic";
use vbap_wire::msglog::{self, MsgEvent, MSG_SUFFIX};

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
pub(super) struct Partial {
    /// Commands of this tick and later only end the mission (not counted).
    pub(super) last_tick: u64,
    /// Scheduled kills (vehicle, kill tick, restart tick or `u64::MAX`): a vehicle's
    /// commands and states of the ticks between are not the mission's (a process that ran
    /// ahead of its kill read and sent them; the simulator's vehicle, gone, did not).
    pub(super) silent: std::sync::Arc<Vec<(u32, u64, u64)>>,
    pub(super) hops: BTreeMap<String, HopAcc>,
    /// (tick, recv_ns) of the body commands this process received.
    pub(super) body_recv: Vec<(u64, u64)>,
    /// (seq, tick, sent_ns) of the body commands received (the coordinator's publications).
    pub(super) body_sent: Vec<(u64, u64, u64)>,
    /// (tick, recv_ns) of the states the coordinator received.
    pub(super) state_recv: Vec<(u64, u64)>,
    pub(super) records: u64,
    pub(super) unparsed: u64,
    /// The vehicles on other hosts than the coordinator's (a run over hosts: their states
    /// and commands cross hosts, hops `state@hosts`, `body@hosts`).
    pub(super) remote: std::sync::Arc<std::collections::BTreeSet<u32>>,
}

/// The hop `hop` of a record from `sender` to `receiver`: `<hop>@hosts` when it crossed
/// hosts (a state of a remote vehicle, a command to one).
fn hop_across<'a>(
    hop: &'a str,
    sender: u32,
    receiver: u32,
    remote: &std::collections::BTreeSet<u32>,
) -> Cow<'a, str> {
    let across = match hop {
        "state" | "state_ack" | "join" => remote.contains(&sender),
        "body" => remote.contains(&receiver),
        _ => false,
    };
    if across {
        Cow::Owned(format!("{hop}@hosts"))
    } else {
        Cow::Borrowed(hop)
    }
}

#[derive(Default)]
pub(super) struct HopAcc {
    pub(super) transport_us: Vec<f64>,
    /// Injected delays carried by the reception records themselves.
    pub(super) inline_ms: Vec<f64>,
    /// Injected delays of `"held"` records (messages the link model delayed).
    pub(super) held_ms: Vec<f64>,
    pub(super) dropped_injected: u64,
    /// Commands the shore replaced with a newer one (Iridium).
    pub(super) superseded: u64,
    pub(super) dropped_overflow: u64,
    /// Received messages whose size is recorded, their bytes summed and the largest.
    pub(super) sized: u64,
    pub(super) bytes: u64,
    pub(super) bytes_max: u64,
    /// Drops of the acoustic hop by verdict (`range`, `collision`, ...).
    pub(super) reasons: BTreeMap<String, u64>,
    /// Commands whose fate the vehicle's link drew (a `held` or `drop` record of the body
    /// hop) but that its process never read (no `recv`: it was killed first): still
    /// commands sent to it, as the simulator counts them. Summed per file by
    /// [`HopAcc::settle`] from the two sets of ticks below, which live for one file only
    /// (an agent's file holds both kinds of record of its own commands).
    pub(super) unread: u64,
    fated: BTreeSet<(u32, u64)>,
    read: BTreeSet<(u32, u64)>,
}

impl HopAcc {
    pub(super) fn merge(&mut self, other: HopAcc) {
        self.transport_us.extend(other.transport_us);
        self.inline_ms.extend(other.inline_ms);
        self.held_ms.extend(other.held_ms);
        self.dropped_injected += other.dropped_injected;
        self.superseded += other.superseded;
        self.dropped_overflow += other.dropped_overflow;
        self.sized += other.sized;
        self.bytes += other.bytes;
        self.bytes_max = self.bytes_max.max(other.bytes_max);
        for (r, n) in other.reasons {
            *self.reasons.entry(r).or_default() += n;
        }
        self.unread += other.unread;
    }

    /// At the end of a file: counts the commands fated there and never read, and forgets
    /// the file's ticks.
    fn settle(&mut self) {
        self.unread += self.fated.difference(&self.read).count() as u64;
        self.fated.clear();
        self.read.clear();
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
    /// The message's size in the compact link encoding, bytes (records that carry it).
    bytes: Option<u64>,
    /// The vehicle whose link the message crossed (receiver of a command, sender of a
    /// state), when the record names it.
    vehicle: Option<u32>,
}

impl Partial {
    /// Adds one record of a process (`is_agent`: a vehicle agent's).
    fn add(&mut self, r: Rec<'_>, is_agent: bool) {
        self.records += 1;
        let plain = r.hop.split('@').next().unwrap_or(r.hop);
        if plain == "body" && r.tick.is_some_and(|t| t >= self.last_tick) {
            return; // "the mission is over": not a command of the mission's links
        }
        if let (Some(v), Some(t)) = (r.vehicle, r.tick) {
            if self
                .silent
                .iter()
                .any(|&(id, from, to)| id == v && t >= from && t < to)
            {
                return; // between its scheduled kill and restart: not the mission's
            }
        }
        let acc = match self.hops.get_mut(r.hop) {
            Some(a) => a,
            None => self.hops.entry(r.hop.to_string()).or_default(),
        };
        if plain == "body" && is_agent {
            if let (Some(v), Some(t)) = (r.vehicle, r.tick) {
                match r.event {
                    MsgEvent::Held | MsgEvent::Drop => {
                        acc.fated.insert((v, t));
                    }
                    MsgEvent::Recv => {
                        acc.read.insert((v, t));
                    }
                }
            }
        }
        match r.event {
            // Dropped: by a full queue, or by the link model (loss, burst, link_down).
            MsgEvent::Drop if plain == ACOUSTIC => {
                *acc.reasons
                    .entry(r.reason.unwrap_or("").to_string())
                    .or_default() += 1;
            }
            MsgEvent::Drop => match r.reason {
                Some("overflow") => acc.dropped_overflow += 1,
                Some("superseded") => acc.superseded += 1,
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
                if let Some(b) = r.bytes {
                    acc.sized += 1;
                    acc.bytes += b;
                    acc.bytes_max = acc.bytes_max.max(b);
                }
                let injected_ms = r.injected_ms.filter(|v| v.is_finite()).unwrap_or(0.0);
                // Integer difference first: the timestamps (~1.8e18 ns) do not fit f64's
                // 53-bit mantissa.
                let wire_ns = recv as i128 - sent as i128;
                acc.transport_us
                    .push(wire_ns as f64 / 1e3 - injected_ms * 1e3);
                if r.injected_ms.is_some() {
                    acc.inline_ms.push(injected_ms);
                }
                if is_agent && plain == "body" {
                    let tick = r.tick.unwrap_or(0);
                    self.body_recv.push((tick, recv));
                    self.body_sent.push((r.seq.unwrap_or(0), tick, sent));
                }
                if plain == "state" {
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
pub(super) enum Format {
    /// `<process>.jsonl`: tracing JSON lines, message records among them (earlier versions).
    Json,
    /// `<process>.msgs.csv`: message records only ([`vbap_wire::msglog`]).
    Csv,
}

/// A log file of `logs/`: its format and process, or None for any other file.
pub(super) fn log_file(path: &Path) -> Option<(Format, String)> {
    let name = path.file_name()?.to_str()?;
    if let Some(process) = name.strip_suffix(MSG_SUFFIX) {
        Some((Format::Csv, process.to_string()))
    } else {
        name.strip_suffix(".jsonl")
            .map(|process| (Format::Json, process.to_string()))
    }
}

/// Parses one log file.
fn read_log(
    path: &Path,
    format: Format,
    is_agent: bool,
    last_tick: u64,
    remote: &std::sync::Arc<std::collections::BTreeSet<u32>>,
    silent: &std::sync::Arc<Vec<(u32, u64, u64)>>,
) -> Result<Partial> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 18, file);
    let mut part = Partial {
        last_tick,
        remote: remote.clone(),
        silent: silent.clone(),
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
    for acc in part.hops.values_mut() {
        acc.settle();
    }
    Ok(part)
}

/// One line of a `.msgs.csv` file.
fn read_csv_line(text: &str, part: &mut Partial, is_agent: bool) {
    let Some(r) = msglog::parse(text) else {
        let line = text.trim_end();
        if !line.is_empty() && !msglog::is_header(line) {
            part.unparsed += 1;
        }
        return;
    };
    let remote = part.remote.clone();
    let hop = hop_across(r.hop, r.sender, r.receiver, &remote);
    part.add(
        Rec {
            event: r.event,
            hop: &hop,
            tick: Some(r.tick),
            seq: r.seq,
            sent_ns: r.sent_ns,
            recv_ns: r.recv_ns,
            injected_ms: r.injected_ns.map(|ns| ns as f64 / 1e6),
            reason: r.reason,
            bytes: r.bytes,
            vehicle: match r.hop.split('@').next().unwrap_or(r.hop) {
                "body" => Some(r.receiver),
                "state" => Some(r.sender),
                _ => None,
            },
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
            bytes: None,
            vehicle: None,
        },
        is_agent,
    );
}

/// The message records of `files` (path, format, process) parsed in parallel, one worker per
/// core, in the order of `files`.
pub(super) fn read_logs(
    files: &[(PathBuf, Format, String)],
    last_tick: u64,
    remote: &std::collections::BTreeSet<u32>,
    silent: Vec<(u32, u64, u64)>,
) -> Result<Vec<(usize, Partial)>> {
    let remote = std::sync::Arc::new(remote.clone());
    let silent = std::sync::Arc::new(silent);
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
                        mine.push((
                            i,
                            read_log(path, *format, is_agent, last_tick, &remote, &silent)?,
                        ));
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
