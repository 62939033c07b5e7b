//! The run directory (DESIGN §8): `mission.toml`, `summary.json`, `vehicles.csv`,
//! `body.csv`, `events.jsonl`, `logs/` (`<process>.jsonl` tracing, `<process>.msgs.csv`
//! message records), `plot.svg`.
//!
//! Floats in CSV are written with Rust's `Display` for `f64`, the shortest string that
//! round-trips, so two runs can be compared byte for byte. Files are appended, never
//! rewritten, except `summary.json`, which is written last (atomically, via a rename).

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::math::Vec3;

/// Header of `vehicles.csv`.
pub const VEHICLES_HEADER: &str = "t,k,id,x,y,z,vx,vy,vz,measurement";
/// Header of `planner_inputs.csv`: `role` is `both` (a member's report that is also
/// fresh), `member` (last known report, not fresh), `fresh` (delivered this tick, not
/// the member's latest) or `joined` (the member was admitted back at this tick; its
/// report repeated).
pub const INPUTS_HEADER: &str = "k,role,id,tick,x,y,z,vx,vy,vz,measurement";
/// Header of `body.csv`.
///
/// After the contract columns: `p_trace`, the trace of the Kalman covariance P (0 before
/// the first estimate), and the true gradient at r (ground truth, from the recorder).
pub const BODY_HEADER: &str =
    "t,k,s,sdot,rx,ry,rz,scale,grad_x,grad_y,grad_z,V,n_vehicles,p_trace,true_grad_x,true_grad_y,true_grad_z";

/// Paths of the files of one run directory.
#[derive(Clone, Debug)]
pub struct RunDir {
    /// The directory itself.
    pub root: PathBuf,
}

impl RunDir {
    /// Uses `root` as the run directory, creating it and `logs/`.
    pub fn create(root: &Path) -> io::Result<Self> {
        std::fs::create_dir_all(root.join("logs"))?;
        Ok(Self {
            root: root.to_path_buf(),
        })
    }
    /// `mission.toml`.
    pub fn mission(&self) -> PathBuf {
        self.root.join("mission.toml")
    }
    /// `summary.json`.
    pub fn summary(&self) -> PathBuf {
        self.root.join("summary.json")
    }
    /// `vehicles.csv`.
    pub fn vehicles(&self) -> PathBuf {
        self.root.join("vehicles.csv")
    }
    /// `body.csv`.
    pub fn body(&self) -> PathBuf {
        self.root.join("body.csv")
    }
    /// `events.jsonl`.
    pub fn events(&self) -> PathBuf {
        self.root.join("events.jsonl")
    }
    /// `logs/<process>.jsonl`.
    pub fn log(&self, process: &str) -> PathBuf {
        self.root.join("logs").join(format!("{process}.jsonl"))
    }
    /// `logs/<process>.msgs.csv`: the process's message records ([`crate::msglog`]).
    pub fn msg_log(&self, process: &str) -> PathBuf {
        self.root
            .join("logs")
            .join(format!("{process}{}", crate::msglog::MSG_SUFFIX))
    }
    /// `planner_inputs.csv`: every argument of every planner step (`vbap replay`).
    pub fn planner_inputs(&self) -> PathBuf {
        self.root.join("planner_inputs.csv")
    }
    /// `plot.svg`.
    pub fn plot(&self) -> PathBuf {
        self.root.join("plot.svg")
    }
}

/// Lengths of the appended files at a checkpoint: a restarted coordinator cuts them back
/// to these, so no row is written twice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileOffsets {
    pub vehicles: u64,
    pub body: u64,
    pub inputs: u64,
    pub events: u64,
}

impl RunDir {
    /// Cuts the appended files back to `o` (what a checkpoint covers).
    pub fn truncate_to(&self, o: &FileOffsets) -> io::Result<()> {
        for (path, len) in [
            (self.vehicles(), o.vehicles),
            (self.body(), o.body),
            (self.planner_inputs(), o.inputs),
            (self.events(), o.events),
        ] {
            if path.exists() {
                OpenOptions::new().write(true).open(&path)?.set_len(len)?;
            }
        }
        Ok(())
    }
}

/// A buffered append-only file that knows its length (what it held when opened plus what
/// was written since), so a checkpoint needs no `stat` of it.
pub struct AppendFile {
    out: BufWriter<File>,
    len: u64,
}

impl AppendFile {
    /// Opens `path` for appending (creating it).
    pub fn open(path: &Path) -> io::Result<Self> {
        let file = OpenOptions::new().create(true).append(true).open(path)?;
        let len = file.metadata()?.len();
        Ok(Self {
            out: BufWriter::with_capacity(1 << 16, file),
            len,
        })
    }
    /// Bytes in the file once flushed.
    pub fn len(&self) -> u64 {
        self.len
    }
    /// True when nothing was ever written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl Write for AppendFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.out.write(buf)?;
        self.len += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// Opens `path` for appending; writes `header` first when the file is new or empty.
fn open_append(path: &Path, header: &str) -> io::Result<AppendFile> {
    let mut w = AppendFile::open(path)?;
    if w.is_empty() {
        writeln!(w, "{header}")?;
    }
    Ok(w)
}

/// One row of `vehicles.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehicleRow {
    pub t: f64,
    pub k: u64,
    pub id: u32,
    pub position: Vec3,
    pub velocity: Vec3,
    pub measurement: f64,
}

/// One row of `body.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyRow {
    pub t: f64,
    pub k: u64,
    pub s: f64,
    pub sdot: f64,
    pub r: Vec3,
    pub scale: f64,
    pub grad: Vec3,
    pub v: f64,
    pub n_vehicles: usize,
    pub p_trace: f64,
    pub true_grad: Vec3,
}

/// One row of `planner_inputs.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputRow<'a> {
    pub k: u64,
    pub role: &'a str,
    pub id: u32,
    pub tick: u64,
    pub position: Vec3,
    pub velocity: Vec3,
    pub measurement: f64,
}

/// Appends rows to `vehicles.csv`, `body.csv` and `planner_inputs.csv`.
pub struct TrackWriter {
    vehicles: AppendFile,
    body: AppendFile,
    inputs: AppendFile,
}

impl TrackWriter {
    /// Opens (appending) the two CSV files of `dir`.
    pub fn open(dir: &RunDir) -> io::Result<Self> {
        Ok(Self {
            vehicles: open_append(&dir.vehicles(), VEHICLES_HEADER)?,
            body: open_append(&dir.body(), BODY_HEADER)?,
            inputs: open_append(&dir.planner_inputs(), INPUTS_HEADER)?,
        })
    }
    /// Appends one planner input row.
    pub fn input(&mut self, r: &InputRow<'_>) -> io::Result<()> {
        writeln!(
            self.inputs,
            "{},{},{},{},{},{},{},{},{},{},{}",
            r.k,
            r.role,
            r.id,
            r.tick,
            r.position.x,
            r.position.y,
            r.position.z,
            r.velocity.x,
            r.velocity.y,
            r.velocity.z,
            r.measurement
        )
    }
    /// Appends one vehicle row.
    pub fn vehicle(&mut self, r: &VehicleRow) -> io::Result<()> {
        writeln!(
            self.vehicles,
            "{},{},{},{},{},{},{},{},{},{}",
            r.t,
            r.k,
            r.id,
            r.position.x,
            r.position.y,
            r.position.z,
            r.velocity.x,
            r.velocity.y,
            r.velocity.z,
            r.measurement
        )
    }
    /// Appends one body row.
    pub fn body(&mut self, r: &BodyRow) -> io::Result<()> {
        writeln!(
            self.body,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.t,
            r.k,
            r.s,
            r.sdot,
            r.r.x,
            r.r.y,
            r.r.z,
            r.scale,
            r.grad.x,
            r.grad.y,
            r.grad.z,
            r.v,
            r.n_vehicles,
            r.p_trace,
            r.true_grad.x,
            r.true_grad.y,
            r.true_grad.z
        )
    }
    /// Flushes both files.
    pub fn flush(&mut self) -> io::Result<()> {
        self.vehicles.flush()?;
        self.inputs.flush()?;
        self.body.flush()
    }
    /// Lengths of `vehicles.csv`, `body.csv` and `planner_inputs.csv` once flushed.
    pub fn lengths(&self) -> (u64, u64, u64) {
        (self.vehicles.len(), self.body.len(), self.inputs.len())
    }
}

/// An entry of `events.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Mission time, s.
    pub t: f64,
    /// Tick.
    pub k: u64,
    /// "join", "lost", "rejoin", "reconfigured", "fault", "link_drop", "holding", "converged", ...
    pub kind: String,
    /// The vehicle concerned, if any.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub vehicle: Option<u32>,
    /// Free-form details.
    #[serde(skip_serializing_if = "serde_json::Value::is_null", default)]
    pub detail: serde_json::Value,
}

/// Appends events to `events.jsonl`.
pub struct EventLog {
    out: AppendFile,
}

impl EventLog {
    /// Opens (appending) `events.jsonl` of `dir`.
    pub fn open(dir: &RunDir) -> io::Result<Self> {
        Ok(Self {
            out: AppendFile::open(&dir.events())?,
        })
    }
    /// Appends one event.
    pub fn push(&mut self, e: &Event) -> io::Result<()> {
        serde_json::to_writer(&mut self.out, e)?;
        self.out.write_all(b"\n")
    }
    /// Flushes.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
    /// Length of `events.jsonl` once flushed.
    pub fn len(&self) -> u64 {
        self.out.len()
    }
    /// True when `events.jsonl` is empty.
    pub fn is_empty(&self) -> bool {
        self.out.is_empty()
    }
}

/// Percentiles of a latency or delay distribution.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Percentiles {
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Percentiles {
    /// Nearest-rank percentiles of `values` (sorted in place); zeros when empty.
    pub fn of(values: &mut [f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        values.sort_by(|a, b| a.total_cmp(b));
        let at = |q: f64| {
            let rank = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len());
            values[rank - 1]
        };
        Self {
            p50: at(0.5),
            p90: at(0.9),
            p99: at(0.99),
            max: values[values.len() - 1],
        }
    }
}

/// Message counts of `summary.json`, over the vehicle ↔ coordinator links (both ways).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MessageCounts {
    /// Messages sent (states and body commands, per receiving vehicle for the latter).
    pub sent: u64,
    /// Messages the link model delivered.
    pub delivered: u64,
    /// Messages the link model dropped (loss, bursts, link down).
    pub dropped_injected: u64,
    /// Messages lost to a full receive queue.
    pub dropped_overflow: u64,
    /// Messages the coordinator rejected (non-finite, foreign, replayed, from the future);
    /// the agents' rejections are in `agent_rejected`.
    pub rejected: u64,
}

/// `summary.json` (DESIGN §8). Fields may be added, never removed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub mission: String,
    pub mode: String,
    pub seed: u64,
    pub converged: bool,
    pub final_distance_to_optimum: Option<f64>,
    pub final_grad_norm: f64,
    pub theorem_5_1_bound: Option<f64>,
    pub in_set_m: Option<bool>,
    pub time_to_converge_s: Option<f64>,
    pub vehicles_started: usize,
    pub vehicles_lost: usize,
    pub vehicles_rejoined: usize,
    pub reconfigurations: usize,
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: f64,
    pub messages: MessageCounts,
    pub latency_us: std::collections::BTreeMap<String, Percentiles>,
    pub wall_time_s: f64,
    pub ticks: u64,
    pub late_ticks: u64,
    pub final_time_s: f64,
    pub final_body_position: [f64; 3],
    pub final_scale: f64,
    pub optimum: Option<[f64; 3]>,
    pub estimated_sigma_m: Option<f64>,
    pub holding_ticks: u64,
    /// For every vehicle process found dead: wall time from its last message to the
    /// coordinator's verdict, ms.
    pub detection_latency_ms: Vec<f64>,
    /// For every admitted restart: wall time from its join request to its admission, ms.
    pub rejoin_latency_ms: Vec<f64>,
    /// Body commands the agents rejected (from their logs).
    pub agent_rejected: u64,
}

impl Summary {
    /// Writes `summary.json` atomically (write a temporary file, then rename).
    pub fn write(&self, dir: &RunDir) -> io::Result<()> {
        let tmp = dir.root.join(".summary.json.tmp");
        let mut text = serde_json::to_string_pretty(self)?;
        text.push('\n');
        std::fs::write(&tmp, text)?;
        std::fs::rename(&tmp, dir.summary())
    }
    /// Reads `summary.json`.
    pub fn read(dir: &RunDir) -> io::Result<Self> {
        let text = std::fs::read_to_string(dir.summary())?;
        serde_json::from_str(&text).map_err(io::Error::other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_nearest_rank() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        let p = Percentiles::of(&mut v);
        assert_eq!((p.p50, p.p90, p.p99, p.max), (50.0, 90.0, 99.0, 100.0));
        assert_eq!(Percentiles::of(&mut []), Percentiles::default());
    }

    #[test]
    fn csv_floats_round_trip() {
        let x = 0.1 + 0.2;
        let s = format!("{x}");
        assert_eq!(s.parse::<f64>().unwrap(), x);
    }
}
