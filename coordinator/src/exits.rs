//! The supervisor's record of the processes it reaped and restarted, beside the checkpoint
//! (`supervisor.exits.jsonl` in the run directory): a death is a fact that survives a
//! coordinator restart.
//!
//! The supervisor appends a line for every process it reaps, before it tells the
//! coordinator (`<m>/supervisor/exits`) or restarts anything, and one for every process it
//! starts again. A coordinator that resumes from its checkpoint reads the deaths: those of
//! processes it still takes for members are acted on as if just reported (`by =
//! "record"`), so a death that happened while no coordinator was listening is never lost.
//! As durable as the checkpoint: written through to the file (no fsync), it survives the
//! death of any process, not that of the host.

use std::io::{self, BufRead as _, Write as _};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::Header;

/// The file's name in the run directory.
pub const FILE: &str = "supervisor.exits.jsonl";

/// One line of the record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExitRecord {
    /// What happened.
    pub event: Event,
    /// `ProcessExit` role ([`ProcessExit::AGENT`], …).
    pub role: u32,
    /// Vehicle id (agents only).
    pub vehicle: u32,
    /// OS process id of the process that ended, or of the new one.
    pub pid: u32,
    /// Incarnation of that process in its slot (1: the first).
    pub incarnation: u32,
    /// Signal that killed it (0: it exited by itself; 0 for a restart).
    pub signal: u32,
    /// Wall-clock time of the event, ns since the Unix epoch.
    pub at_ns: u64,
}

/// What a line of the record says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Event {
    /// The supervisor reaped the process.
    Died,
    /// The supervisor started a new process in the slot.
    Restarted,
    /// The supervisor saw the process stopped by a signal (`signal`): alive, not running.
    Stopped,
    /// The supervisor saw the stopped process run again.
    Continued,
}

impl ExitRecord {
    /// The death that `exit` reports, of the process of incarnation `incarnation`.
    pub fn died(exit: &ProcessExit, incarnation: u32) -> Self {
        Self {
            event: Event::Died,
            role: exit.role,
            vehicle: exit.vehicle,
            pid: exit.pid,
            incarnation,
            signal: exit.signal,
            at_ns: exit.died_ns,
        }
    }

    /// The report a coordinator acts on for a death of the record.
    pub fn as_exit(&self) -> ProcessExit {
        ProcessExit {
            header: Header::from_sender(Header::SUPERVISOR),
            role: self.role,
            vehicle: self.vehicle,
            pid: self.pid,
            signal: self.signal,
            died_ns: self.at_ns,
        }
    }
}

/// The record's file in run directory `root`.
pub fn path(root: &Path) -> PathBuf {
    root.join(FILE)
}

/// Appends `rec` to the record of run directory `root` (one line, written through).
pub fn append(root: &Path, rec: &ExitRecord) -> io::Result<()> {
    let mut line = serde_json::to_string(rec).map_err(io::Error::other)?;
    line.push('\n');
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path(root))?;
    f.write_all(line.as_bytes())?;
    f.flush()
}

/// Every line of the record of run directory `root`, in order; none when there is no
/// record; a line that does not parse (cut by a crash while written) is skipped.
pub fn read(root: &Path) -> Vec<ExitRecord> {
    let Ok(f) = std::fs::File::open(path(root)) else {
        return Vec::new();
    };
    io::BufReader::new(f)
        .lines()
        .map_while(Result::ok)
        .filter_map(|l| serde_json::from_str(&l).ok())
        .collect()
}

/// The agents' deaths of the record of run directory `root`, as reports.
pub fn agent_deaths(root: &Path) -> Vec<ProcessExit> {
    read(root)
        .iter()
        .filter(|r| r.event == Event::Died && r.role == ProcessExit::AGENT)
        .map(ExitRecord::as_exit)
        .collect()
}

/// The agents of the record of run directory `root` stopped at or before `before_ns` (wall
/// clock, ns since the Unix epoch) and neither continued nor dead since, as
/// [`ProcessExit::STOPPED`] reports: processes that will not report until continued.
pub fn agents_stopped_by(root: &Path, before_ns: u64) -> Vec<ProcessExit> {
    let mut stopped: std::collections::BTreeMap<u32, ExitRecord> = Default::default();
    for r in read(root)
        .into_iter()
        .filter(|r| r.role == ProcessExit::AGENT)
    {
        match r.event {
            Event::Stopped if r.at_ns <= before_ns => {
                stopped.insert(r.pid, r);
            }
            Event::Continued | Event::Died => {
                stopped.remove(&r.pid);
            }
            Event::Stopped | Event::Restarted => {}
        }
    }
    stopped
        .values()
        .map(|r| ProcessExit {
            role: ProcessExit::STOPPED,
            ..r.as_exit()
        })
        .collect()
}

/// [`agent_deaths`] of processes that died at or before `before_ns` (wall clock, ns since
/// the Unix epoch).
pub fn agent_deaths_by(root: &Path, before_ns: u64) -> Vec<ProcessExit> {
    let mut deaths = agent_deaths(root);
    deaths.retain(|e| e.died_ns <= before_ns);
    deaths
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deaths_and_restarts_are_read_back_in_order_and_a_torn_line_is_skipped() {
        let dir = std::env::temp_dir().join(format!("vbap-exits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let _ = std::fs::remove_file(path(&dir));
        assert!(read(&dir).is_empty());
        let exit = ProcessExit {
            role: ProcessExit::AGENT,
            vehicle: 3,
            pid: 41,
            signal: 9,
            died_ns: 7,
            ..ProcessExit::default()
        };
        append(&dir, &ExitRecord::died(&exit, 1)).unwrap();
        let restart = ExitRecord {
            event: Event::Restarted,
            pid: 42,
            incarnation: 2,
            signal: 0,
            at_ns: 8,
            ..ExitRecord::died(&exit, 1)
        };
        append(&dir, &restart).unwrap();
        // A crash in the middle of a line.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(path(&dir))
            .unwrap();
        f.write_all(b"{\"event\":\"died\",\"ro").unwrap();
        let all = read(&dir);
        assert_eq!(all.len(), 2);
        assert_eq!(all[1], restart);
        let deaths = agent_deaths(&dir);
        assert_eq!(deaths.len(), 1);
        assert_eq!(
            (deaths[0].vehicle, deaths[0].pid, deaths[0].signal),
            (3, 41, 9)
        );
        assert_eq!(deaths[0].died_ns, 7);
        assert_eq!(deaths[0].header.sender, Header::SUPERVISOR);
        // Read again by a running coordinator: only deaths at or before the given time.
        assert_eq!(agent_deaths_by(&dir, 7), deaths);
        assert!(agent_deaths_by(&dir, 6).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_agent_is_stopped_from_its_stop_until_it_continues_or_dies() {
        let dir = std::env::temp_dir().join(format!("vbap-stops-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let _ = std::fs::remove_file(path(&dir));
        let rec = |event, vehicle, pid, at_ns| ExitRecord {
            event,
            role: ProcessExit::AGENT,
            vehicle,
            pid,
            incarnation: 1,
            signal: if event == Event::Stopped { 19 } else { 0 },
            at_ns,
        };
        for r in [
            rec(Event::Stopped, 1, 51, 10),
            rec(Event::Stopped, 2, 52, 11),
            rec(Event::Stopped, 3, 53, 12),
            rec(Event::Continued, 2, 52, 13),
            rec(Event::Died, 3, 53, 14),
            rec(Event::Stopped, 4, 54, 20),
        ] {
            append(&dir, &r).unwrap();
        }
        let at = |before| {
            agents_stopped_by(&dir, before)
                .iter()
                .map(|e| (e.role, e.vehicle, e.pid, e.signal, e.died_ns))
                .collect::<Vec<_>>()
        };
        assert_eq!(at(15), vec![(ProcessExit::STOPPED, 1, 51, 19, 10)]);
        assert_eq!(at(20).len(), 2, "a stop is taken from its time on");
        assert!(agent_deaths(&dir).iter().all(|e| e.vehicle == 3));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
