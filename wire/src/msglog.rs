//! Per-message records: `logs/<process>.msgs.csv`, the writer and the parser.
//!
//! Every receiver writes one line per message it takes off IPC (`recv`), one per verdict of
//! the link model on it (`held`, `drop`) and one per message lost to a full queue (`drop`,
//! reason `overflow`). `vbap analyze` reads them for per-hop latency,
//! drops and loop timing; `vbap bench` for the tick rate. This module is the only place
//! that knows the format.
//!
//! # Format
//!
//! CSV, one record per line, the header [`MSG_HEADER`] first:
//!
//! ```text
//! event,hop,sender,receiver,tick,seq,sent_ns,recv_ns,injected_ns,reason,bytes
//! recv,state,3,4294967294,120,121,1795437897283832923,1795437897283851120,,,68
//! held,state,3,4294967294,120,,,,2050000000,,
//! drop,body,4294967294,3,121,,,,,loss,
//! ```
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `event` | | `recv` (taken off IPC), `held` (the link model delays it), `drop` (lost) |
//! | `hop` | | `state`, `body`, `field_request`, `field_reply`, … |
//! | `sender`, `receiver` | | vehicle id, or `4294967294` the coordinator, `4294967293` the field server |
//! | `tick` | ticks | the tick the message belongs to |
//! | `seq` | | the sender's sequence number (`recv`) |
//! | `sent_ns` | ns since the Unix epoch | sender's wall clock just before sending (`recv`) |
//! | `recv_ns` | ns since the Unix epoch | receiver's wall clock once it holds the message (`recv`) |
//! | `injected_ns` | ns of mission time | the delay the link model adds (`held`) |
//! | `reason` | | why it was dropped (`drop`): `loss`, `burst`, `link_down`, `overflow`, … |
//! | `bytes` | bytes | the message's size in the compact link encoding (`recv` of a vehicle's command or report; `crate::compact`) |
//!
//! A cell that does not apply to the event is empty. All numbers are unsigned integers.
//! Files of earlier versions have no `bytes` column ([`MSG_HEADER_BEFORE_BYTES`]); their
//! lines parse with no size.
//! `hop` and `reason` are identifiers: a comma or line break in them is written as `_`.
//! The file is appended to (a restarted process continues it, the header is not repeated)
//! and buffered (64 KiB); a vehicle agent flushes it before every wait, i.e. at least once
//! per tick, so an agent killed with SIGKILL loses at most the records of the tick it was
//! working on (those taken since its last wait), never half a line.
//!
//! # On or off
//!
//! Records are on unless the environment variable [`RECORDS_ENV`] (`VBAP_MSG_RECORDS`) is
//! `off` (or `0`, `false`); the log level (`RUST_LOG`) does not switch them, so
//! `RUST_LOG=info` keeps what `vbap analyze` needs.
//!
//! Run directories of earlier versions carry the same records as JSON lines in
//! `logs/<process>.jsonl` (target `vbap::msg`; the `held` record's hop is named
//! `<hop>_link` and its delay is `injected_ms`): the readers accept both.
//!
//! # Cost
//!
//! The writer formats integers only ([`itoa`]), into a line buffer reused for every record,
//! then a 64 KiB [`BufWriter`]: no allocation and no float formatting per record. The first
//! write error is reported once with `tracing::warn!`; the records after it are not written
//! (they are diagnostics: the process carries on).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Environment variable switching the records: `on` (the default; also `1`, `true`, empty)
/// or `off` (`0`, `false`).
pub const RECORDS_ENV: &str = "VBAP_MSG_RECORDS";

/// The value of [`RECORDS_ENV`] as a switch: `None` (unset) and `on`/`1`/`true`/empty are on,
/// `off`/`0`/`false` off (any case); anything else is an error naming the variable.
pub fn parse_records_switch(value: Option<&str>) -> Result<bool, String> {
    match value.map(|v| v.trim().to_ascii_lowercase()).as_deref() {
        None | Some("" | "on" | "1" | "true") => Ok(true),
        Some("off" | "0" | "false") => Ok(false),
        Some(other) => Err(format!(
            "{RECORDS_ENV}={other:?}: must be \"on\" or \"off\" (message records for vbap analyze)"
        )),
    }
}

/// Whether this process writes message records ([`RECORDS_ENV`]; a malformed value counts
/// as on: the front door refuses it before any process starts).
pub fn records_on() -> bool {
    parse_records_switch(std::env::var(RECORDS_ENV).ok().as_deref()).unwrap_or(true)
}

/// Header line of every message-record file.
pub const MSG_HEADER: &str =
    "event,hop,sender,receiver,tick,seq,sent_ns,recv_ns,injected_ns,reason,bytes";

/// Header line of the files of earlier versions, without the `bytes` column (their
/// records parse too, with no size).
pub const MSG_HEADER_BEFORE_BYTES: &str =
    "event,hop,sender,receiver,tick,seq,sent_ns,recv_ns,injected_ns,reason";

/// True for a header line of either version.
pub fn is_header(line: &str) -> bool {
    let line = line.trim_end();
    line == MSG_HEADER || line == MSG_HEADER_BEFORE_BYTES
}

/// File name suffix: `<process>.msgs.csv` (named with the other run-directory files).
pub use crate::rundir::MSG_SUFFIX;

/// Target of per-message records in the JSON logs of earlier versions (the records now have
/// their own file and switch): the readers still accept them.
pub const MSG_TARGET: &str = "vbap::msg";

/// Buffer size of the writer, bytes.
const BUFFER: usize = 1 << 16;

/// What happened to a message at its receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsgEvent {
    /// Taken off IPC (before the link model's verdict).
    Recv,
    /// Delivered after a delay the link model added (`injected_ns`).
    Held,
    /// Lost: by the link model (`loss`, `burst`, `link_down`, …) or a full queue
    /// (`overflow`).
    Drop,
}

impl MsgEvent {
    /// The `event` cell.
    pub fn as_str(self) -> &'static str {
        match self {
            MsgEvent::Recv => "recv",
            MsgEvent::Held => "held",
            MsgEvent::Drop => "drop",
        }
    }
}

/// One parsed record, borrowed from its line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MsgRecord<'a> {
    pub event: MsgEvent,
    /// `"state"`, `"body"`, `"field_request"`, `"field_reply"`, …
    pub hop: &'a str,
    pub sender: u32,
    pub receiver: u32,
    pub tick: u64,
    pub seq: Option<u64>,
    /// Sender's wall clock, ns since the Unix epoch.
    pub sent_ns: Option<u64>,
    /// Receiver's wall clock, ns since the Unix epoch.
    pub recv_ns: Option<u64>,
    /// Held: the delay the link model added (mission time, ns).
    pub injected_ns: Option<u64>,
    /// Drop: `"loss"`, `"burst"`, `"link_down"`, `"overflow"`, …
    pub reason: Option<&'a str>,
    /// Recv: the message's size in the compact link encoding (`crate::compact`), bytes,
    /// where the receiver knows it (the vehicles' commands and reports).
    pub bytes: Option<u64>,
}

/// Parses one line (the header and malformed lines give None). A trailing `\n` or `\r\n`
/// is allowed.
pub fn parse(line: &str) -> Option<MsgRecord<'_>> {
    let line = line.strip_suffix('\n').unwrap_or(line);
    let line = line.strip_suffix('\r').unwrap_or(line);
    let mut cells = line.split(',');
    let mut next = || cells.next();
    let event = match next()? {
        "recv" => MsgEvent::Recv,
        "held" => MsgEvent::Held,
        "drop" => MsgEvent::Drop,
        _ => return None,
    };
    let hop = next().filter(|h| !h.is_empty())?;
    let sender = next()?.parse().ok()?;
    let receiver = next()?.parse().ok()?;
    let tick = next()?.parse().ok()?;
    let seq = optional(next()?)?;
    let sent_ns = optional(next()?)?;
    let recv_ns = optional(next()?)?;
    let injected_ns = optional(next()?)?;
    let reason = Some(next()?).filter(|r| !r.is_empty());
    // Absent in the files of earlier versions.
    let bytes = match next() {
        Some(cell) => optional(cell)?,
        None => None,
    };
    if next().is_some() {
        return None; // more cells than columns: not one of our lines
    }
    Some(MsgRecord {
        event,
        hop,
        sender,
        receiver,
        tick,
        seq,
        sent_ns,
        recv_ns,
        injected_ns,
        reason,
        bytes,
    })
}

/// An optional integer cell: empty → `Some(None)`, a number → `Some(Some(n))`, anything
/// else → `None` (malformed).
fn optional(cell: &str) -> Option<Option<u64>> {
    if cell.is_empty() {
        Some(None)
    } else {
        cell.parse().ok().map(Some)
    }
}

/// The open file of an enabled [`MsgLog`].
struct Sink {
    out: BufWriter<File>,
    /// The record being formatted, reused (no allocation per record).
    line: Vec<u8>,
    path: PathBuf,
    /// A write failed (reported once): nothing more is written.
    failed: bool,
}

impl Sink {
    fn cell_str(&mut self, s: &str) {
        if s.bytes().any(|b| matches!(b, b',' | b'\n' | b'\r')) {
            self.line.extend(s.bytes().map(|b| match b {
                b',' | b'\n' | b'\r' => b'_',
                b => b,
            }));
        } else {
            self.line.extend_from_slice(s.as_bytes());
        }
        self.line.push(b',');
    }

    fn cell_u64(&mut self, v: u64) {
        self.line
            .extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
        self.line.push(b',');
    }

    /// Starts a record: the four cells every event has, then `tick`.
    fn begin(&mut self, event: MsgEvent, hop: &str, sender: u32, receiver: u32, tick: u64) {
        self.line.clear();
        self.line.extend_from_slice(event.as_str().as_bytes());
        self.line.push(b',');
        self.cell_str(hop);
        self.cell_u64(u64::from(sender));
        self.cell_u64(u64::from(receiver));
        self.cell_u64(tick);
    }

    /// Ends the record with its `bytes` cell (the last cell wrote its separator) and
    /// writes it.
    fn end(&mut self, bytes: Option<u64>) {
        if let Some(b) = bytes {
            self.line
                .extend_from_slice(itoa::Buffer::new().format(b).as_bytes());
        }
        self.line.push(b'\n');
        if let Err(e) = self.out.write_all(&self.line) {
            self.fail(&e);
        }
    }

    fn fail(&mut self, e: &std::io::Error) {
        self.failed = true;
        tracing::warn!(
            file = %self.path.display(),
            error = %e,
            "writing message records failed; no more are written"
        );
    }
}

/// Buffered writer of `logs/<process>.msgs.csv`; disabled = writes nothing. Flushes on drop.
pub struct MsgLog {
    sink: Option<Sink>,
}

impl MsgLog {
    /// A log that writes nothing.
    pub fn disabled() -> Self {
        Self { sink: None }
    }

    /// Opens `path` for appending (creating parent dirs); writes the header line when the
    /// file is empty.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)?;
        }
        let file = OpenOptions::new().create(true).append(true).open(path)?;
        let empty = file.metadata()?.len() == 0;
        let mut out = BufWriter::with_capacity(BUFFER, file);
        if empty {
            out.write_all(MSG_HEADER.as_bytes())?;
            out.write_all(b"\n")?;
        }
        Ok(Self {
            sink: Some(Sink {
                out,
                line: Vec::with_capacity(256),
                path: path.to_path_buf(),
                failed: false,
            }),
        })
    }

    /// The message log beside a process's tracing log: `X/<p>.jsonl` -> `X/<p>.msgs.csv`.
    /// Disabled when `log_file` is None or records are switched off ([`records_on`]); the
    /// tracing filter plays no part.
    pub fn beside(log_file: Option<&Path>) -> std::io::Result<Self> {
        match log_file {
            Some(log_file) if records_on() => {
                Self::open(&log_file.with_extension(&MSG_SUFFIX[1..]))
            }
            _ => Ok(Self::disabled()),
        }
    }

    /// Whether this log has a file (records are written to it unless a write failed).
    pub fn is_enabled(&self) -> bool {
        self.sink.is_some()
    }

    /// The sink, when enabled and not failed.
    #[inline]
    fn live(&mut self) -> Option<&mut Sink> {
        self.sink.as_mut().filter(|s| !s.failed)
    }

    /// A message taken off IPC: the sender's `seq` and wall-clock `sent_ns`, the
    /// receiver's wall-clock `recv_ns` (ns since the Unix epoch).
    #[allow(clippy::too_many_arguments)] // the record's columns, named at every call site
    pub fn recv(
        &mut self,
        hop: &str,
        sender: u32,
        receiver: u32,
        tick: u64,
        seq: u64,
        sent_ns: u64,
        recv_ns: u64,
    ) {
        self.recv_sized(hop, sender, receiver, tick, (seq, sent_ns, recv_ns), None);
    }

    /// [`MsgLog::recv`] of a message of `bytes` bytes (None: unknown); `stamps` are its
    /// seq, sent_ns and recv_ns.
    pub fn recv_sized(
        &mut self,
        hop: &str,
        sender: u32,
        receiver: u32,
        tick: u64,
        (seq, sent_ns, recv_ns): (u64, u64, u64),
        bytes: Option<u64>,
    ) {
        let Some(s) = self.live() else { return };
        s.begin(MsgEvent::Recv, hop, sender, receiver, tick);
        s.cell_u64(seq);
        s.cell_u64(sent_ns);
        s.cell_u64(recv_ns);
        s.line.extend_from_slice(b",,");
        s.end(bytes);
    }

    /// [`MsgLog::recv_now`] of a message of `bytes` bytes in the compact link encoding
    /// (`crate::compact`).
    pub fn recv_now_sized(&mut self, hop: &str, h: &crate::msg::Header, receiver: u32, bytes: u64) {
        if self.sink.is_some() {
            let now = crate::msg::wall_ns();
            let stamps = (h.seq, h.sent_ns, now);
            self.recv_sized(hop, h.sender, receiver, h.tick, stamps, Some(bytes));
        }
    }

    /// A message with header `h` taken off IPC by `receiver` now ([`MsgLog::recv`] with the
    /// header's sender, tick, seq and send stamp, and the wall clock now).
    pub fn recv_now(&mut self, hop: &str, h: &crate::msg::Header, receiver: u32) {
        if self.sink.is_some() {
            let now = crate::msg::wall_ns();
            self.recv(hop, h.sender, receiver, h.tick, h.seq, h.sent_ns, now);
        }
    }

    /// A message the link model delivers late. `injected_s`: seconds of mission time the
    /// link model holds the message (stored as integer ns, rounded; a negative or
    /// non-finite delay leaves the cell empty).
    pub fn held(&mut self, hop: &str, sender: u32, receiver: u32, tick: u64, injected_s: f64) {
        let Some(s) = self.live() else { return };
        s.begin(MsgEvent::Held, hop, sender, receiver, tick);
        s.line.extend_from_slice(b",,,");
        let ns = injected_s * 1e9;
        if ns.is_finite() && ns >= 0.0 {
            // Saturates above u64::MAX ns (585 years).
            s.cell_u64(ns.round() as u64);
        } else {
            s.line.push(b',');
        }
        s.line.push(b',');
        s.end(None);
    }

    /// A message lost, for `reason` (`"loss"`, `"burst"`, `"link_down"`, `"overflow"`, …).
    pub fn drop(&mut self, hop: &str, sender: u32, receiver: u32, tick: u64, reason: &str) {
        let Some(s) = self.live() else { return };
        s.begin(MsgEvent::Drop, hop, sender, receiver, tick);
        s.line.extend_from_slice(b",,,,");
        s.cell_str(reason);
        s.end(None);
    }

    /// Writes the buffered records to the file.
    pub fn flush(&mut self) {
        let Some(s) = self.live() else { return };
        if let Err(e) = s.out.flush() {
            s.fail(&e);
        }
    }
}

impl Drop for MsgLog {
    fn drop(&mut self) {
        self.flush();
    }
}

impl std::fmt::Debug for MsgLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.sink {
            Some(s) => f.debug_tuple("MsgLog").field(&s.path).finish(),
            None => f.write_str("MsgLog(disabled)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vbap-msglog-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn lines(path: &Path) -> Vec<String> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(str::to_string)
            .collect()
    }

    #[test]
    fn round_trip_of_each_event() {
        let dir = temp("round");
        let path = dir.join("logs/coordinator.msgs.csv");
        let mut log = MsgLog::open(&path).unwrap();
        assert!(log.is_enabled());
        let (sent, recv) = (1_795_437_897_283_832_923, 1_795_437_897_283_851_120);
        log.recv("state", 3, u32::MAX - 1, 120, 121, sent, recv);
        log.held("state", 3, u32::MAX - 1, 120, 2.05);
        log.drop("body", u32::MAX - 1, 3, u64::MAX, "loss");
        log.held("body", 0, 1, 7, f64::NAN);
        let h = crate::msg::Header::new(u32::MAX - 1, 9, 0.45, 10);
        log.recv_now_sized("body", &h, 3, 1234);
        drop(log);
        let l = lines(&path);
        assert_eq!(l.len(), 6, "{l:?}");
        let sized = parse(&l[5]).unwrap();
        assert_eq!(
            (sized.hop, sized.tick, sized.seq, sized.bytes),
            ("body", 9, Some(10), Some(1234))
        );
        assert_eq!(l[0], MSG_HEADER);
        assert_eq!(parse(&l[0]), None, "the header is not a record");
        assert_eq!(
            parse(&l[1]),
            Some(MsgRecord {
                event: MsgEvent::Recv,
                hop: "state",
                sender: 3,
                receiver: u32::MAX - 1,
                tick: 120,
                seq: Some(121),
                sent_ns: Some(sent),
                recv_ns: Some(recv),
                injected_ns: None,
                reason: None,
                bytes: None,
            })
        );
        assert_eq!(
            parse(&l[2]),
            Some(MsgRecord {
                event: MsgEvent::Held,
                hop: "state",
                sender: 3,
                receiver: u32::MAX - 1,
                tick: 120,
                seq: None,
                sent_ns: None,
                recv_ns: None,
                injected_ns: Some(2_050_000_000),
                reason: None,
                bytes: None,
            })
        );
        assert_eq!(
            parse(&l[3]),
            Some(MsgRecord {
                event: MsgEvent::Drop,
                hop: "body",
                sender: u32::MAX - 1,
                receiver: 3,
                tick: u64::MAX,
                seq: None,
                sent_ns: None,
                recv_ns: None,
                injected_ns: None,
                reason: Some("loss"),
                bytes: None,
            })
        );
        let nan = parse(&l[4]).unwrap();
        assert_eq!((nan.event, nan.injected_ns), (MsgEvent::Held, None));
        // The documented example lines parse.
        assert_eq!(
            l[3],
            "drop,body,4294967294,3,18446744073709551615,,,,,loss,"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn malformed_lines_give_none() {
        let good = "recv,state,3,4294967294,120,121,10,20,,,80";
        assert_eq!(parse(good).and_then(|r| r.bytes), Some(80));
        assert!(parse(&format!("{good}\r\n")).is_some());
        // A line of an earlier version (no `bytes` column).
        let before = "recv,state,3,4294967294,120,121,10,20,,";
        assert_eq!(parse(before).map(|r| (r.tick, r.bytes)), Some((120, None)));
        assert!(is_header(MSG_HEADER_BEFORE_BYTES) && is_header(MSG_HEADER));
        for bad in [
            "",
            MSG_HEADER,
            "recv,state,3,4294967294,120,121,10,20,", // a cell short
            "recv,state,3,4294967294,120,121,10,20,,,,", // a cell too many
            "recv,state,3,4294967294,120,121,10,20,,,8.5", // a size not an integer
            "sent,state,3,4294967294,120,121,10,20,,", // unknown event
            "recv,,3,4294967294,120,121,10,20,,",     // no hop
            "recv,state,,4294967294,120,121,10,20,,", // no sender
            "recv,state,3,4294967296,120,121,10,20,,", // receiver beyond u32
            "recv,state,3,4294967294,-1,121,10,20,,", // negative tick
            "recv,state,3,4294967294,120,x,10,20,,",  // not a number
            "held,state,3,4294967294,120,,,,2.5,",    // a float
            "recv,state,3,4294967294,120,121,10,20recv,state,3,4294967294,120,121,10,20,,",
            "{\"target\":\"vbap::msg\"}",
        ] {
            assert_eq!(parse(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn separators_in_identifiers_are_replaced() {
        let dir = temp("sep");
        let path = dir.join("a.msgs.csv");
        let mut log = MsgLog::open(&path).unwrap();
        log.drop("st,ate", 1, 2, 3, "link\ndown");
        drop(log);
        let l = lines(&path);
        let r = parse(&l[1]).unwrap();
        assert_eq!((r.hop, r.reason), ("st_ate", Some("link_down")));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn disabled_writes_nothing() {
        let dir = temp("disabled");
        let mut log = MsgLog::disabled();
        assert!(!log.is_enabled());
        log.recv("state", 0, 1, 2, 3, 4, 5);
        log.held("state", 0, 1, 2, 0.5);
        log.drop("state", 0, 1, 2, "loss");
        log.flush();
        drop(log);
        // No log file: disabled, nothing created.
        let log = MsgLog::beside(None).unwrap();
        assert!(!log.is_enabled());
        assert!(!dir.exists());
    }

    #[test]
    fn appending_does_not_repeat_the_header() {
        let dir = temp("append");
        let path = dir.join("logs/vehicle_agent_0.msgs.csv");
        for k in 0..3 {
            let mut log = MsgLog::open(&path).unwrap();
            log.recv("body", u32::MAX - 1, 0, k, k, 10, 20);
        }
        let l = lines(&path);
        assert_eq!(l.len(), 4, "{l:?}");
        assert_eq!(l.iter().filter(|l| l.as_str() == MSG_HEADER).count(), 1);
        let ticks: Vec<u64> = l.iter().filter_map(|l| parse(l)).map(|r| r.tick).collect();
        assert_eq!(ticks, [0, 1, 2]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn write_errors_do_not_panic() {
        // Every write to /dev/full fails (ENOSPC).
        let mut log = MsgLog::open(Path::new("/dev/full")).unwrap();
        for k in 0..10_000 {
            log.recv("state", 0, 1, k, k, 10, 20);
        }
        log.flush();
        assert!(log.sink.as_ref().is_some_and(|s| s.failed));
        log.drop("state", 0, 1, 2, "loss");
        log.flush();
    }

    #[test]
    fn the_switch_reads_on_and_off_and_refuses_the_rest() {
        for on in [
            None,
            Some(""),
            Some("on"),
            Some("ON"),
            Some("1"),
            Some("true"),
        ] {
            assert_eq!(parse_records_switch(on), Ok(true), "{on:?}");
        }
        for off in [Some("off"), Some("Off"), Some("0"), Some("false")] {
            assert_eq!(parse_records_switch(off), Ok(false), "{off:?}");
        }
        let err = parse_records_switch(Some("maybe")).unwrap_err();
        assert!(err.starts_with("VBAP_MSG_RECORDS=\"maybe\""), "{err}");
    }
}
