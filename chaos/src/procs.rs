//! The process set of a run as the campaign sees it through /proc: slots, command lines,
//! liveness, children, signals, and whether a process is up by its own log.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use nix::sys::signal::Signal;
use serde_json::Value;

/// A process slot of the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Slot {
    FieldServer,
    Coordinator,
    Agent(u32),
}

impl Slot {
    /// "vehicle_agent 3", "coordinator", "field_server".
    pub fn label(self) -> String {
        match self {
            Slot::FieldServer => "field_server".into(),
            Slot::Coordinator => "coordinator".into(),
            Slot::Agent(i) => format!("vehicle_agent {i}"),
        }
    }
    pub(super) fn kind(self) -> Target {
        match self {
            Slot::FieldServer => Target::FieldServer,
            Slot::Coordinator => Target::Coordinator,
            Slot::Agent(_) => Target::Agents,
        }
    }
}

/// A target kind of `--targets`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Target {
    Agents,
    Coordinator,
    FieldServer,
}

/// The slot of a process from its command line (`argv[0]` and `--id`); None for others.
pub fn slot_of(cmdline: &[String]) -> Option<Slot> {
    let exe = Path::new(cmdline.first()?).file_name()?.to_str()?;
    match exe {
        "field_server" => Some(Slot::FieldServer),
        "coordinator" => Some(Slot::Coordinator),
        "vehicle_agent" => {
            let i = cmdline.iter().position(|a| a == "--id")?;
            Some(Slot::Agent(cmdline.get(i + 1)?.parse().ok()?))
        }
        _ => None,
    }
}

pub(super) fn cmdline(pid: u32) -> Option<Vec<String>> {
    let raw = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
    Some(
        raw.split(|b| *b == 0)
            .filter(|s| !s.is_empty())
            .map(|s| String::from_utf8_lossy(s).into_owned())
            .collect(),
    )
}

pub(super) use vbap_ipc::process::process_alive as alive;

/// The children of `pid` (of every thread of it).
pub(super) fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return out;
    };
    for t in tasks.flatten() {
        if let Ok(text) = std::fs::read_to_string(t.path().join("children")) {
            out.extend(
                text.split_whitespace()
                    .filter_map(|p| p.parse::<u32>().ok()),
            );
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Sends `sig` to `pid`; false when there is no such process (any more). The pid was just
/// checked to be the process of the run we mean (its command line).
pub(super) fn send(pid: u32, sig: Signal) -> bool {
    match i32::try_from(pid) {
        Ok(pid) if pid > 0 => nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig).is_ok(),
        _ => false,
    }
}

pub(super) fn epoch_s(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// What the campaign saw of one process of the set.
pub(super) struct Seen {
    pub slot: Slot,
    pub cmd: Vec<String>,
    pub first_unix_s: f64,
}

/// True when process `pid` of `slot` is up by its own log (`logs/<process>.jsonl`, the
/// lines after its `started` line): the coordinator and the field server once they say
/// `… up`, an agent once it says `agent up` — and, when it is a restarted agent joining,
/// once it says it was admitted back. A process still starting is no target: the
/// coordinator cannot lose what it has not admitted.
pub(super) fn is_up(run_dir: &Path, pid: u32, slot: Slot) -> bool {
    let name = match slot {
        Slot::FieldServer => "field_server".to_string(),
        Slot::Coordinator => "coordinator".to_string(),
        Slot::Agent(i) => format!("vehicle_agent_{i}"),
    };
    let lines = json_lines(&run_dir.join("logs").join(format!("{name}.jsonl")));
    let message = |l: &Value| message(l).unwrap_or("").to_string();
    let Some(start) = lines.iter().rposition(|l| {
        message(l) == "started"
            && l.pointer("/fields/pid").and_then(Value::as_u64) == Some(u64::from(pid))
    }) else {
        return false;
    };
    let mut joining = None;
    for l in &lines[start + 1..] {
        let msg = message(l);
        if msg == "started" {
            break;
        }
        match slot {
            Slot::Agent(_) if msg == "agent up" => {
                joining = Some(l.pointer("/fields/joining").and_then(Value::as_bool) == Some(true));
                if joining == Some(false) {
                    return true;
                }
            }
            Slot::Agent(_) if joining == Some(true) && msg.contains("admitted") => return true,
            Slot::Agent(_) => {}
            _ if msg.ends_with(" up") => return true,
            _ => {}
        }
    }
    false
}

/// Live processes started with the run's mission file, as "pid command line".
pub(super) fn leftover_processes(mission_arg: &str, seen: &BTreeMap<u32, Seen>) -> Vec<String> {
    let mut out = BTreeMap::new();
    if let Ok(entries) = std::fs::read_dir("/proc") {
        for e in entries.flatten() {
            let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
                continue;
            };
            if let Some(c) = cmdline(pid) {
                if c.iter().any(|a| a == mission_arg) && alive(pid) {
                    out.insert(pid, c.join(" "));
                }
            }
        }
    }
    for (pid, s) in seen {
        if alive(*pid) && cmdline(*pid).as_ref() == Some(&s.cmd) {
            out.insert(*pid, s.cmd.join(" "));
        }
    }
    out.into_iter().map(|(p, c)| format!("{p} {c}")).collect()
}

/// The `message` of a tracing JSON line (`fields.message`).
pub(super) fn message(line: &Value) -> Option<&str> {
    line.pointer("/fields/message").and_then(Value::as_str)
}

/// A line of a JSON-lines file, parsed; None for a line that is not JSON.
pub(super) fn json_lines(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .map(|t| {
            t.lines()
                .filter_map(|l| serde_json::from_str(l).ok())
                .collect()
        })
        .unwrap_or_default()
}
