//! The run directory (docs/ARCHITECTURE.md §10): `mission.toml`, `summary.json`, `vehicles.csv`,
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

use vbap_math::Vec3;

/// `runs/<label>-<UTC timestamp>`: where a run goes by default (label: the mission name),
/// a batch (`<name>-batch`) or a chaos campaign (`<name>-chaos`).
pub fn default_run_dir(label: &str) -> Result<PathBuf, time::error::Error> {
    let now = time::OffsetDateTime::now_utc();
    let stamp = now.format(&time::format_description::parse_borrowed::<2>(
        "[year][month][day]T[hour][minute][second]Z",
    )?)?;
    Ok(Path::new("runs").join(format!("{label}-{stamp}")))
}

/// Header of `vehicles.csv`.
pub const VEHICLES_HEADER: &str = "t,k,id,x,y,z,vx,vy,vz,measurement";
/// The columns `vehicles.csv` has after [`VEHICLES_HEADER`] when the mission moves beyond
/// the paper's ideal vehicle (`vehicles.model = "glider"`, a current or land): `bx,by,bz`
/// the position the vehicle believes and reports (dead reckoning since its last fix),
/// `wx,wy,wz` its velocity through the water, `cx,cy,cz` the current at its true position.
/// `x,y,z` and `vx,vy,vz` stay the truth (position, velocity over the ground).
pub const VEHICLES_MOTION_COLUMNS: &str = "bx,by,bz,wx,wy,wz,cx,cy,cz";
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

/// Header of `formation.csv`: one row per started vehicle per tick, from the true states.
///
/// `contact`: `contact` | `surfaced` | `submerged` | `link_down` | `dead` | `rejoining`;
/// `info_age_s`: mission time since the state of the coordinator's newest delivered report
/// of the vehicle was taken, s (empty: none delivered, or dead); `slot_error`: true
/// distance from its slot of the current design ÷ design spacing; `nearest_ratio`: true
/// distance to the nearest other live vehicle ÷ design spacing; `in_formation`: 1 when
/// alive and `slot_error` ≤ `vbap_math::fit::IN_FORMATION`. Empty field = none.
pub const FORMATION_HEADER: &str =
    "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation";
/// The values of `formation.csv`'s `contact` column ([`FORMATION_HEADER`]), in the order
/// the viewer's JSON and the exported NetCDF flags number them (0…5).
pub const CONTACT_STATES: [&str; 6] = [
    "contact",
    "surfaced",
    "submerged",
    "link_down",
    "dead",
    "rejoining",
];
/// Header of `truth.csv`: one row per tick. `V_true_over_VU`: V of (II.2) from the true
/// states of the formation's members ÷ V_U; `V_seen_over_VU`: the coordinator's own V ÷
/// V_U; `min_pair_ratio`, `max_slot_error`: over live vehicles, ÷ design spacing;
/// `sdot_over_v0`: ṡ of (IV.4) ÷ v0.
pub const TRUTH_HEADER: &str = "t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0";

/// Paths of the files of one run directory.
#[derive(Clone, Debug)]
pub struct RunDir {
    /// The directory itself.
    pub root: PathBuf,
}

/// File name suffix of a process's message records: `logs/<process>.msgs.csv`.
pub const MSG_SUFFIX: &str = ".msgs.csv";

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
    /// `logs/<process>.msgs.csv`: the process's message records (`crate::msglog`).
    pub fn msg_log(&self, process: &str) -> PathBuf {
        self.root
            .join("logs")
            .join(format!("{process}{MSG_SUFFIX}"))
    }
    /// `planner_inputs.csv`: every argument of every planner step (`vbap replay`).
    pub fn planner_inputs(&self) -> PathBuf {
        self.root.join("planner_inputs.csv")
    }
    /// `plot.svg`.
    pub fn plot(&self) -> PathBuf {
        self.root.join("plot.svg")
    }
    /// `formation.csv`: per vehicle and tick, the true formation ([`FORMATION_HEADER`]).
    pub fn formation(&self) -> PathBuf {
        self.root.join("formation.csv")
    }
    /// `truth.csv`: per tick, the true figures ([`TRUTH_HEADER`]).
    pub fn truth(&self) -> PathBuf {
        self.root.join("truth.csv")
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
    pub formation: u64,
    pub truth: u64,
}

impl RunDir {
    /// Cuts the appended files back to `o` (what a checkpoint covers).
    pub fn truncate_to(&self, o: &FileOffsets) -> io::Result<()> {
        for (path, len) in [
            (self.vehicles(), o.vehicles),
            (self.body(), o.body),
            (self.planner_inputs(), o.inputs),
            (self.events(), o.events),
            (self.formation(), o.formation),
            (self.truth(), o.truth),
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
    /// The [`VEHICLES_MOTION_COLUMNS`]: (believed position, water velocity, current);
    /// None for a mission of ideal vehicles.
    pub motion: Option<(Vec3, Vec3, Vec3)>,
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

pub use crate::csv_line::Num;
use crate::csv_line::{Line, Memo};

/// A vehicle's state as the cells of a row: position (3), velocity (3), measurement.
fn state_cells(position: &Vec3, velocity: &Vec3, measurement: f64) -> [f64; 7] {
    [
        position.x,
        position.y,
        position.z,
        velocity.x,
        velocity.y,
        velocity.z,
        measurement,
    ]
}

/// Appends rows to `vehicles.csv`, `body.csv` and `planner_inputs.csv`.
pub struct TrackWriter {
    vehicles: AppendFile,
    body: AppendFile,
    inputs: AppendFile,
    line: Line,
    /// The text of the tick's time (every row of `vehicles.csv` of a tick has it).
    time: Memo<1>,
    /// The text of each vehicle's state (by id), written on its rows of both
    /// `planner_inputs.csv` and `vehicles.csv` (the same report, in lockstep on ideal links).
    states: Memo<7>,
}

impl TrackWriter {
    /// Opens (appending) the CSV files of `dir`; `vehicles.csv` with the
    /// [`VEHICLES_MOTION_COLUMNS`] when `motion`.
    pub fn open(dir: &RunDir, motion: bool) -> io::Result<Self> {
        let header = if motion {
            format!("{VEHICLES_HEADER},{VEHICLES_MOTION_COLUMNS}")
        } else {
            VEHICLES_HEADER.to_string()
        };
        Ok(Self {
            vehicles: open_append(&dir.vehicles(), &header)?,
            body: open_append(&dir.body(), BODY_HEADER)?,
            inputs: open_append(&dir.planner_inputs(), INPUTS_HEADER)?,
            line: Line::default(),
            time: Memo::default(),
            states: Memo::default(),
        })
    }
    /// Appends one planner input row.
    pub fn input(&mut self, r: &InputRow<'_>) -> io::Result<()> {
        self.line
            .int(r.k)
            .text(r.role)
            .int(r.id)
            .int(r.tick)
            .nums_memo(
                &state_cells(&r.position, &r.velocity, r.measurement),
                r.id as usize,
                &mut self.states,
            )
            .finish(&mut self.inputs)
    }
    /// Appends one vehicle row.
    pub fn vehicle(&mut self, r: &VehicleRow) -> io::Result<()> {
        let line = self
            .line
            .nums_memo(&[r.t], 0, &mut self.time)
            .int(r.k)
            .int(r.id)
            .nums_memo(
                &state_cells(&r.position, &r.velocity, r.measurement),
                r.id as usize,
                &mut self.states,
            );
        if let Some((b, w, c)) = &r.motion {
            line.vec3(b).vec3(w).vec3(c);
        }
        line.finish(&mut self.vehicles)
    }
    /// Appends one body row.
    pub fn body(&mut self, r: &BodyRow) -> io::Result<()> {
        self.line
            .num(r.t)
            .int(r.k)
            .num(r.s)
            .num(r.sdot)
            .vec3(&r.r)
            .num(r.scale)
            .vec3(&r.grad)
            .num(r.v)
            .int(r.n_vehicles)
            .num(r.p_trace)
            .vec3(&r.true_grad)
            .finish(&mut self.body)
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

/// One row of `formation.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FormationRow<'a> {
    pub t: f64,
    pub k: u64,
    pub id: u32,
    pub contact: &'a str,
    pub info_age_s: Option<f64>,
    pub slot_error: Option<f64>,
    pub nearest_ratio: Option<f64>,
    pub in_formation: bool,
}

/// One row of `truth.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthRow {
    pub t: f64,
    pub k: u64,
    pub v_true_over_vu: f64,
    pub v_seen_over_vu: f64,
    pub min_pair_ratio: Option<f64>,
    pub max_slot_error: Option<f64>,
    pub n_alive: usize,
    pub n_in_formation: usize,
    pub sdot_over_v0: f64,
}

/// Appends rows to `formation.csv` and `truth.csv`.
pub struct TruthWriter {
    formation: AppendFile,
    truth: AppendFile,
    line: Line,
    /// The text of the tick's time (every row of `formation.csv` of a tick has it).
    time: Memo<1>,
}

impl TruthWriter {
    /// Opens (appending) the two files of `dir`.
    pub fn open(dir: &RunDir) -> io::Result<Self> {
        Ok(Self {
            formation: open_append(&dir.formation(), FORMATION_HEADER)?,
            truth: open_append(&dir.truth(), TRUTH_HEADER)?,
            line: Line::default(),
            time: Memo::default(),
        })
    }
    /// Appends one `formation.csv` row.
    pub fn formation(&mut self, r: &FormationRow<'_>) -> io::Result<()> {
        self.line
            .nums_memo(&[r.t], 0, &mut self.time)
            .int(r.k)
            .int(r.id)
            .text(r.contact)
            .opt(r.info_age_s)
            .opt(r.slot_error)
            .opt(r.nearest_ratio)
            .int(u8::from(r.in_formation))
            .finish(&mut self.formation)
    }
    /// Appends one `truth.csv` row.
    pub fn truth(&mut self, r: &TruthRow) -> io::Result<()> {
        self.line
            .num(r.t)
            .int(r.k)
            .num(r.v_true_over_vu)
            .num(r.v_seen_over_vu)
            .opt(r.min_pair_ratio)
            .opt(r.max_slot_error)
            .int(r.n_alive)
            .int(r.n_in_formation)
            .num(r.sdot_over_v0)
            .finish(&mut self.truth)
    }
    /// Flushes both files.
    pub fn flush(&mut self) -> io::Result<()> {
        self.formation.flush()?;
        self.truth.flush()
    }
    /// Lengths of `formation.csv` and `truth.csv` once flushed.
    pub fn lengths(&self) -> (u64, u64) {
        (self.formation.len(), self.truth.len())
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
    /// Messages the link model dropped (loss, bursts, link down; and the reports a lost
    /// vehicle's link still held when it was lost: a glider that dies under water takes
    /// them with it; the coordinator records each, reason `lost`).
    pub dropped_injected: u64,
    /// Messages lost to a full receive queue.
    pub dropped_overflow: u64,
    /// Commands the shore replaced with a newer one before the vehicle's next session
    /// (Iridium, `[links.iridium]`): neither delivered nor lost (the newer says it again).
    #[serde(default)]
    pub superseded: u64,
    /// Messages the coordinator rejected (non-finite, foreign, replayed, from the future);
    /// the agents' rejections are in `agent_rejected`.
    pub rejected: u64,
}

/// The `link_bytes` object of `summary.json`: the bytes of the vehicles' own messages, each
/// as the compact link encoding writes it (`crate::compact`, exact precision).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkBytes {
    /// Commands to vehicles (one per vehicle a tick), their mean and largest size, bytes.
    pub commands: u64,
    pub command_mean_b: f64,
    pub command_max_b: u64,
    /// Reports the link model delivered to the coordinator, and the size of one, bytes.
    pub reports: u64,
    pub report_b: u64,
    /// Bytes per vehicle and day of mission time: commands down, reports up.
    pub down_b_per_vehicle_day: f64,
    pub up_b_per_vehicle_day: f64,
    /// Iridium's sessions and limits (`[links.iridium]`); absent on other links. Under
    /// Iridium `commands` counts the commands sessions carried (the newest at the shore
    /// as each successful session opened), not those the shore replaced.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iridium: Option<IridiumTotals>,
}

/// The `link_bytes.iridium` object of `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IridiumTotals {
    /// Sessions the vehicles opened (every vehicle over the whole mission), and those
    /// that failed.
    pub sessions: u64,
    pub sessions_failed: u64,
    /// Commands over `down_limit`, and what was done with them ("split" | "refuse").
    pub commands_over_limit: u64,
    pub oversize: String,
}

/// The `acoustic` object of `summary.json` (`[acoustic]`): what became of every frame at
/// every receiver (each frame is decided once at each vehicle alive to hear it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AcousticTotals {
    /// The size of a frame, bytes.
    pub frame_b: u64,
    /// Decoded.
    pub heard: u64,
    /// Beyond detection range.
    pub range: u64,
    /// Missed while the receiver transmitted (half-duplex).
    pub deaf: u64,
    /// Lost to another frame overlapping it at the receiver.
    pub collision: u64,
    /// Detected beyond communication range, not decoded.
    pub undecoded: u64,
    /// Lost to the decoding draw.
    pub noise: u64,
}

impl AcousticTotals {
    /// Adds another receiver's receptions (the frame size is the mission's: kept, or taken
    /// when none yet).
    pub fn merge(&mut self, o: &AcousticTotals) {
        self.frame_b = self.frame_b.max(o.frame_b);
        self.heard += o.heard;
        self.range += o.range;
        self.deaf += o.deaf;
        self.collision += o.collision;
        self.undecoded += o.undecoded;
        self.noise += o.noise;
    }

    /// Every reception decided.
    pub fn total(&self) -> u64 {
        self.heard + self.range + self.deaf + self.collision + self.undecoded + self.noise
    }
}

/// `summary.json` (docs/ARCHITECTURE.md §10). Fields may be added, never removed.
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
    /// Largest V of (II.2) ÷ V_U from the vehicles' TRUE states (the coordinator's own,
    /// from its possibly stale view, is `formation.max_V_seen_over_VU`).
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
    /// Ticks whose scale the planner held at the stability envelope's floor
    /// (`Mission::held_min_scale`, above `formation.min_scale`; docs/ENVELOPE.md).
    #[serde(default)]
    pub scale_held_ticks: u64,
    /// For every vehicle process found dead: wall time from its last message to the
    /// coordinator's verdict, ms.
    pub detection_latency_ms: Vec<f64>,
    /// For every admitted restart: wall time from its join request to its admission, ms.
    pub rejoin_latency_ms: Vec<f64>,
    /// Body commands the agents rejected (from their logs).
    pub agent_rejected: u64,
    /// The outcome in a word or three, judged from the true states: "converged",
    /// "converged, near collisions", "converged, formation broken", "stalled", "stalled,
    /// formation broken", "diverged",
    /// "not converged, formation broken", "not converged", "interrupted", and "formation
    /// kept" / "formation broken" for a field without an optimum (see
    /// `coordinator::truth::verdict`).
    #[serde(default)]
    pub verdict: String,
    /// Why: sentences naming vehicles, times and figures.
    #[serde(default)]
    pub reasons: Vec<String>,
    /// The true formation over the run (from `formation.csv` / `truth.csv` figures).
    #[serde(default)]
    pub formation: Option<FormationSummary>,
    /// What the vehicles' own links carried, in the compact link encoding
    /// (`crate::compact`). Since the neighbour lists (absent before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub link_bytes: Option<LinkBytes>,
    /// The acoustic channel's receptions (`[acoustic]`; absent without).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acoustic: Option<AcousticTotals>,
}

/// The `formation` object of `summary.json`: the formation judged from the vehicles' true
/// states. Ratios are ÷ the design spacing (neighbour spacing `d0` × scale `k`) at the
/// time; V ratios ÷ V_U of Theorem 4.1.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FormationSummary {
    /// Largest V of (II.2) from the true states of the formation's members ÷ V_U.
    #[serde(rename = "max_V_true_over_VU")]
    pub max_v_true_over_vu: f64,
    /// Largest V the coordinator computed from its own (possibly stale) view ÷ V_U.
    #[serde(rename = "max_V_seen_over_VU")]
    pub max_v_seen_over_vu: f64,
    /// Share of ticks with the true V above V_U, 0..1.
    #[serde(rename = "share_ticks_V_true_above_VU")]
    pub share_ticks_v_true_above_vu: f64,
    /// Mission time by which every vehicle had been in contact at least once, s (a glider
    /// that has not surfaced yet flies the plan it was deployed with); none if never.
    #[serde(default)]
    pub all_in_contact_t: Option<f64>,
    /// Share of the ticks from `all_in_contact_t` on with the true V above V_U, 0..1.
    #[serde(rename = "share_ticks_V_true_above_VU_after_contact", default)]
    pub share_ticks_v_true_above_vu_after_contact: Option<f64>,
    /// Smallest distance between two live vehicles ÷ design spacing, when and which pair.
    pub min_pair_ratio: Option<f64>,
    pub min_pair_t: Option<f64>,
    pub min_pair_vehicles: Option<[u32; 2]>,
    /// Ticks with some pair closer than `near_collision_ratio` × spacing.
    pub near_collision_ticks: u64,
    /// Largest distance of a live vehicle from its slot ÷ spacing, which vehicle, when.
    pub worst_slot_error: Option<f64>,
    pub worst_slot_vehicle: Option<u32>,
    pub worst_slot_t: Option<f64>,
    /// Vehicles alive at the end, and how many of them were in formation.
    pub alive_at_end: usize,
    pub in_formation_at_end: usize,
    /// Live vehicles out of formation at the end (ids).
    pub out_of_formation_at_end: Vec<u32>,
    /// Distance of every started vehicle from its slot at the end ÷ spacing (index = id;
    /// none when dead).
    pub final_slot_error: Vec<Option<f64>>,
    /// Longest time without new information from each vehicle (index = id), s: the
    /// largest age of the coordinator's newest report of it.
    pub longest_contact_gap_s: Vec<Option<f64>>,
    /// Mission time spent stalled (ṡ below `stall_sdot_fraction` × v0 for longer than
    /// `stall_after_s`), s, and whether the run ended stalled.
    pub stalled_s: f64,
    pub stalled_at_end: bool,
    /// The thresholds used (÷ spacing, ÷ v0, s).
    pub in_formation_ratio: f64,
    pub near_collision_ratio: f64,
    pub stall_sdot_fraction: f64,
    pub stall_after_s: f64,
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
    fn tiny_and_huge_floats_are_short_and_round_trip() {
        for x in [
            1e-300,
            -1e-300,
            5e-324,
            f64::MIN_POSITIVE,
            1.2345678901234567e-25,
            9.99e-5,
            1e-4,
            0.1 + 0.2,
            -3.5,
            0.0,
            -0.0,
            123456.789,
            9.9e15,
            1e16,
            f64::MAX,
        ] {
            let s = Num(x).to_string();
            assert!(s.len() <= 24, "{x:?} written as {s} ({} chars)", s.len());
            let back = s.parse::<f64>().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:?} written as {s}");
        }
        // Ordinary values keep their plain decimal form.
        assert_eq!(Num(0.25).to_string(), "0.25");
        assert_eq!(Num(3.0).to_string(), "3");
        assert_eq!(Num(1e-25).to_string(), "1e-25");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
    }

    #[test]
    fn csv_floats_round_trip() {
        let x = 0.1 + 0.2;
        let s = format!("{x}");
        assert_eq!(s.parse::<f64>().unwrap(), x);
    }
}
