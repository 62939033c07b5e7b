//! The run as the viewer holds it: every tick's body, truth figures, vehicle positions and
//! contact, and the events, read from the run directory's files (by column name) as far as
//! they are written. The same model serves a finished run (read once) and a running one
//! (read again whenever the files grow: [`Model::poll`]).

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use vbap_math::formation::FormationDesign;
use vbap_mission::acoustic::AcousticModel;
use vbap_mission::config::Mission;
use vbap_mission::field::Field;
use vbap_mission::link::LinkModel;
use vbap_wire::rundir::RunDir;

mod read;

use read::Files;

/// Contact states of `formation.csv`, in the order of their codes in the JSON (0…5); 6 is
/// a state this viewer does not know.
pub use vbap_wire::rundir::CONTACT_STATES as CONTACTS;

/// Code of the contact state `s` ([`CONTACTS`]).
pub fn contact_code(s: &str) -> u8 {
    CONTACTS.iter().position(|c| *c == s).unwrap_or(6) as u8
}

/// A vehicle at a tick: true position (x, y; length unit; a dead vehicle stays where it was
/// last seen), contact code, age of the coordinator's newest report of it (s) and its
/// distance from its slot ÷ design spacing (both absent when unknown).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vehicle {
    pub id: u32,
    pub x: f64,
    pub y: f64,
    pub contact: u8,
    pub age: Option<f64>,
    pub slot_error: Option<f64>,
}

/// The body at a tick (`body.csv`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Body {
    /// Centre r (length unit).
    pub x: f64,
    pub y: f64,
    /// Scale k (III.3).
    pub scale: f64,
    /// Members of the formation design.
    pub n_vehicles: usize,
    /// |∇T_est − ∇T| at the body centre (field unit per length unit), when the true
    /// gradient is recorded.
    pub grad_error: Option<f64>,
}

/// The truth figures of a tick (`truth.csv`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Truth {
    /// V of (II.2) from the true states ÷ V_U, and the coordinator's own ÷ V_U.
    pub v_true: Option<f64>,
    pub v_seen: Option<f64>,
    /// ṡ ÷ v0.
    pub sdot: Option<f64>,
}

/// Everything known of one tick.
#[derive(Clone, Debug, Default)]
pub struct Tick {
    pub t: f64,
    pub body: Option<Body>,
    pub truth: Option<Truth>,
    pub vehicles: Vec<Vehicle>,
}

/// An event of `events.jsonl` worth showing (link drops are only counted).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Event {
    pub t: f64,
    pub k: u64,
    pub kind: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<u32>,
    /// `detail.why` or `detail.cause`, when there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub why: Option<String>,
}

/// The run, as far as its files are written.
pub struct Model {
    dir: RunDir,
    pub mission: Mission,
    pub field: Field,
    files: Files,
    ticks: Vec<Tick>,
    events: Vec<Event>,
    link_drops: u64,
    /// summary.json is written: the run is over and every file whole.
    finished: bool,
    verdict: Option<String>,
    /// Last known position of each vehicle (by id).
    last_pos: Vec<Option<(f64, f64)>>,
    /// The design of (V.7) for each member count seen (`None`: none can be designed).
    designs: BTreeMap<usize, Option<FormationDesign>>,
    /// Bumped whenever something new was read.
    version: u64,
    /// The mission's links (Iridium sessions: a function of the mission alone).
    link_model: LinkModel,
    /// The mission's acoustic channel (None without `[acoustic]`).
    channel: Option<Arc<AcousticModel>>,
}

impl Model {
    /// The run in `dir` (its `mission.toml` must be there), read as far as it is written.
    pub fn open(dir: &Path) -> Result<Self> {
        let run = RunDir {
            root: dir.to_path_buf(),
        };
        let mission = Mission::load(&run.mission())
            .with_context(|| format!("{}: not a run directory", dir.display()))?;
        let field = mission.field();
        let link_model = LinkModel::new(&mission);
        let channel = AcousticModel::new(&mission);
        let mut model = Self {
            link_model,
            channel,
            files: Files::new(&run),
            dir: run,
            mission,
            field,
            ticks: Vec::new(),
            events: Vec::new(),
            link_drops: 0,
            finished: false,
            verdict: None,
            last_pos: Vec::new(),
            designs: BTreeMap::new(),
            version: 0,
        };
        model.poll()?;
        Ok(model)
    }

    /// What vehicle `id`'s links did in `[from, to)` (s): the bits of
    /// `crate::frames::LINK_SESSION`, `LINK_SESSION_FAILED`, `LINK_ACOUSTIC`. Both are
    /// functions of the mission (`LinkModel::sessions`, `AcousticModel::sent_between`), as
    /// `contact.svg` draws them.
    pub fn links_between(&self, id: u32, from: f64, to: f64) -> u8 {
        use crate::frames::{LINK_ACOUSTIC, LINK_SESSION, LINK_SESSION_FAILED};
        let mut bits = 0;
        if self.link_model.iridium().is_some() {
            for s in self.link_model.sessions(id, from, to) {
                bits |= if s.ok {
                    LINK_SESSION
                } else {
                    LINK_SESSION_FAILED
                };
            }
        }
        if let Some(ch) = &self.channel {
            if !ch.sent_between(id, from, to).is_empty() {
                bits |= LINK_ACOUSTIC;
            }
        }
        bits
    }

    /// Reads what the files gained since the last poll; true when anything was new. A file
    /// cut back (a coordinator resumed from its checkpoint) makes the whole run read again.
    pub fn poll(&mut self) -> Result<bool> {
        if self.finished {
            return Ok(false);
        }
        // summary.json is written after the last rows are flushed: seen before this
        // poll's reads, every row is in by the end of them.
        let finished = self.files.summary.exists();
        let before = (
            self.ticks.len(),
            self.ready(),
            self.events.len(),
            self.link_drops,
        );
        // In the order the coordinator flushes them: a tick's rows of truth.csv are in the
        // file only after its vehicles', body and formation rows.
        let shrunk = self.read_vehicles()?
            | self.read_body()?
            | self.read_formation()?
            | self.read_truth()?
            | self.read_events()?;
        if shrunk {
            self.files = Files::new(&self.dir);
            self.ticks.clear();
            self.events.clear();
            self.link_drops = 0;
            self.last_pos.clear();
            self.version += 1;
            return self.poll().map(|_| true);
        }
        if finished {
            self.finished = true;
            self.verdict = std::fs::read_to_string(&self.files.summary)
                .ok()
                .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
                .and_then(|v| v.get("verdict")?.as_str().map(str::to_owned));
        }
        let changed = finished
            || before
                != (
                    self.ticks.len(),
                    self.ready(),
                    self.events.len(),
                    self.link_drops,
                );
        if changed {
            self.version += 1;
        }
        Ok(changed)
    }

    /// Number of ticks whose rows are all in (0, 1, … ready − 1).
    pub fn ready(&self) -> usize {
        if self.finished {
            return self.ticks.len();
        }
        let f = &self.files;
        [&f.vehicles, &f.body, &f.formation, &f.truth]
            .iter()
            .filter(|c| c.tail.exists())
            .map(|c| c.last_k.map_or(0, |k| k as usize + 1))
            .min()
            .unwrap_or(0)
            .min(self.ticks.len())
    }

    /// The ticks read (index: tick number); only the first [`Model::ready`] are whole.
    pub fn ticks(&self) -> &[Tick] {
        &self.ticks[..self.ready()]
    }

    /// The events read so far (without link drops).
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Messages the link model dropped so far (`link_drop` events).
    pub fn link_drops(&self) -> u64 {
        self.link_drops
    }

    /// True once the run wrote its summary.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// The verdict of summary.json, once written.
    pub fn verdict(&self) -> Option<&str> {
        self.verdict.as_deref()
    }

    /// Changes with every poll that read something.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The design for `n` members (design_regular, as the planner designs it).
    pub fn design(&self, n: usize) -> Option<&FormationDesign> {
        self.designs.get(&n).and_then(Option::as_ref)
    }

    /// The optimum of the field at `t` (x, y), when it has one.
    pub fn optimum(&self, t: f64) -> Option<(f64, f64)> {
        self.field
            .optimum(t, self.mission.mission.goal)
            .map(|o| (o.x, o.y))
    }
}
