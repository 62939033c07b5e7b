//! Turns ticks into the run-directory files and the summary (docs/ARCHITECTURE.md §10).
//!
//! The recorder is the omniscient logger of a simulator: it knows the true field and the
//! true optimum, which the planner never sees. The in-process simulator and the
//! coordinator process both use it, so their files are written by the same code.

use std::io;
use std::sync::Arc;

use vbap_ipc::compact::StateReport;
use vbap_math::formation::FormationDesign;
use vbap_math::Vec3;
use vbap_mission::config::{Mission, Oversize};
use vbap_mission::field::ScalarField;
use vbap_mission::link::LinkModel;
use vbap_mission::rundir::{
    BodyRow, Event, EventLog, InputRow, IridiumTotals, LinkBytes, RunDir, TrackWriter, TruthWriter,
    VehicleRow,
};

mod summary;

use crate::fleet::Fleet;
use crate::planner::{Command, Report, Told};
use crate::truth::{self, TruthStats};

/// The envelope's floor of the scale of `mission` when the planner is held above
/// `formation.min_scale` (`Mission::held_min_scale`), and what sets it.
fn scale_floor(mission: &Mission) -> Option<(f64, &'static str)> {
    let env = mission.held_envelope()?;
    let floor = mission.scale_floor(Some(&env));
    let by = match env.limit {
        vbap_math::envelope::ScaleLimit::Links => "the links",
        _ => "the time step",
    };
    (floor > mission.formation.min_scale).then_some((floor, by))
}

/// The running figures of `summary.json` (checkpointed with the coordinator).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RecorderStats {
    /// Largest V ÷ V_U the coordinator computed from its own view (`seen`).
    pub max_v_over_vu: f64,
    pub last_outside: Option<f64>,
    pub ever_inside: bool,
    pub holding_ticks: u64,
    pub ticks: u64,
    pub last_t: f64,
    pub last_r: Vec3,
    pub last_scale: f64,
    pub vehicles_started: usize,
    pub vehicles_lost: usize,
    pub vehicles_rejoined: usize,
    pub was_holding: bool,
    /// The running figures of the true formation.
    pub truth: TruthStats,
    /// Ticks whose body scale sat at the envelope's floor (`Mission::held_min_scale`,
    /// above `formation.min_scale`): the planner held the scale there.
    #[serde(default)]
    pub scale_held_ticks: u64,
    /// Whether the last tick's scale was held (for the `scale_held` event).
    #[serde(default)]
    pub was_scale_held: bool,
    /// The body's distance from the optimum over the last quarter of the planned ticks
    /// (the tracking rule of the verdict, `truth::verdict`).
    #[serde(default)]
    pub tail: TailStats,
    /// The optimum at the first tick, and whether it has moved since (by more than 1e-9
    /// of the tolerance): a moving field's optimum is tracked, not converged to.
    #[serde(default)]
    pub first_optimum: Option<Vec3>,
    #[serde(default)]
    pub optimum_moved: bool,
    /// The bytes of the vehicles' own messages so far.
    #[serde(default)]
    pub links: LinkTotals,
}

/// The running totals of the vehicles' own messages, in the compact link encoding.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinkTotals {
    /// Commands sent (one per vehicle a tick), their bytes summed and the largest.
    pub commands: u64,
    pub command_bytes: u64,
    pub command_max: u64,
    /// Reports the link model delivered.
    pub reports: u64,
    /// Commands over the link's per-message limit (Iridium).
    #[serde(default)]
    pub over_limit: u64,
}

impl LinkTotals {
    /// The `link_bytes` object of the summary, for `vehicles` vehicles over `duration` s of
    /// mission time.
    pub fn summary(&self, vehicles: usize, duration: f64, model: &LinkModel) -> LinkBytes {
        let report_b = StateReport::LEN as u64;
        let vehicle_days = vehicles.max(1) as f64 * duration.max(f64::MIN_POSITIVE) / 86_400.0;
        let iridium = model.iridium().map(|i| {
            let sessions: Vec<_> = (0..vehicles as u32)
                .flat_map(|v| model.sessions(v, 0.0, duration))
                .collect();
            IridiumTotals {
                sessions: sessions.len() as u64,
                sessions_failed: sessions.iter().filter(|s| !s.ok).count() as u64,
                commands_over_limit: self.over_limit,
                oversize: match i.oversize {
                    Oversize::Split => "split",
                    Oversize::Refuse => "refuse",
                }
                .to_string(),
            }
        });
        LinkBytes {
            iridium,
            commands: self.commands,
            command_mean_b: self.command_bytes as f64 / self.commands.max(1) as f64,
            command_max_b: self.command_max,
            reports: self.reports,
            report_b,
            down_b_per_vehicle_day: self.command_bytes as f64 / vehicle_days,
            up_b_per_vehicle_day: (self.reports * report_b) as f64 / vehicle_days,
        }
    }
}

/// The body's distance from the optimum over the last quarter of a run, length unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TailStats {
    /// Mission time of the first tick counted, s.
    pub from_t: Option<f64>,
    /// Ticks counted, their summed and largest distance.
    pub ticks: u64,
    pub sum: f64,
    pub max: f64,
}

/// Records ticks, accumulates the figures of `summary.json`.
pub struct Recorder {
    mission: Mission,
    field: Arc<dyn ScalarField>,
    dir: RunDir,
    tracks: TrackWriter,
    truth_files: TruthWriter,
    events: EventLog,
    stats: RecorderStats,
    /// The envelope's floor of the scale when it is above `formation.min_scale`, and what
    /// set it ("the links", "the time step").
    scale_floor: Option<(f64, &'static str)>,
}

impl Recorder {
    /// Opens the CSV and event files of `dir` (appending), judging by the mission's own field.
    pub fn open(mission: &Mission, dir: &RunDir) -> io::Result<Self> {
        Self::open_with(mission, dir, Arc::new(mission.field()))
    }

    /// [`Recorder::open`] judging by `field` (the field the sensors sample).
    pub fn open_with(
        mission: &Mission,
        dir: &RunDir,
        field: Arc<dyn ScalarField>,
    ) -> io::Result<Self> {
        let stats = RecorderStats {
            max_v_over_vu: 0.0,
            last_outside: None,
            ever_inside: false,
            holding_ticks: 0,
            ticks: 0,
            last_t: 0.0,
            last_r: mission.start_vec(),
            last_scale: 1.0,
            vehicles_started: mission.vehicles.count,
            vehicles_lost: 0,
            vehicles_rejoined: 0,
            was_holding: false,
            truth: TruthStats::new(mission),
            scale_held_ticks: 0,
            was_scale_held: false,
            tail: TailStats::default(),
            first_optimum: None,
            optimum_moved: false,
            links: LinkTotals::default(),
        };
        Self::resume_with(mission, dir, stats, field)
    }

    /// Opens the files of `dir` (appending) with running figures `stats` (a checkpoint's),
    /// judging by `field` (the field the sensors sample).
    pub fn resume_with(
        mission: &Mission,
        dir: &RunDir,
        stats: RecorderStats,
        field: Arc<dyn ScalarField>,
    ) -> io::Result<Self> {
        Ok(Self {
            mission: mission.clone(),
            field,
            dir: dir.clone(),
            tracks: TrackWriter::open(dir, mission.moves_beyond_ideal())?,
            truth_files: TruthWriter::open(dir)?,
            events: EventLog::open(dir)?,
            stats,
            scale_floor: scale_floor(mission),
        })
    }

    /// Counts a tick whose `scale` sits at the envelope's floor, and writes a
    /// `scale_held` event when it comes to sit there.
    fn scale_held(&mut self, t: f64, k: u64, scale: f64) -> io::Result<()> {
        let held = self
            .scale_floor
            .is_some_and(|(floor, _)| scale <= floor * (1.0 + 1e-9));
        if held {
            self.stats.scale_held_ticks += 1;
        }
        if held && !self.stats.was_scale_held {
            self.events.push(&Event {
                t,
                k,
                kind: "scale_held".into(),
                vehicle: None,
                detail: serde_json::json!({
                    "scale": scale,
                    "min_scale": self.mission.formation.min_scale,
                    "by": self.scale_floor.map_or("", |(_, by)| by),
                    "links": self.mission.links_in_words(),
                }),
            })?;
        }
        self.stats.was_scale_held = held;
        Ok(())
    }

    /// The running figures.
    pub fn stats(&self) -> &RecorderStats {
        &self.stats
    }

    /// Appends an event to `events.jsonl` (a `lost` or `rejoin` event, made by
    /// [`crate::membership`], is counted in the summary).
    pub fn event(&mut self, e: Event) -> io::Result<()> {
        match e.kind.as_str() {
            "lost" => self.stats.vehicles_lost += 1,
            "rejoin" => self.stats.vehicles_rejoined += 1,
            _ => {}
        }
        self.events.push(&e)
    }

    /// Writes a `fault` event for every scheduled fault starting at tick `k`.
    pub fn faults_starting(&mut self, k: u64) -> io::Result<()> {
        let dt = self.mission.mission.dt;
        let starting: Vec<_> = self
            .mission
            .faults
            .iter()
            .filter(|f| vbap_mission::faults::tick_at(f.at, dt) == k)
            .cloned()
            .collect();
        for f in starting {
            self.events.push(&Event {
                t: k as f64 * dt,
                k,
                kind: "fault".into(),
                vehicle: Some(f.vehicle),
                detail: serde_json::json!({ "fault": f.kind.as_str(), "at": f.at, "until": f.until, "value": f.value }),
            })?;
        }
        Ok(())
    }

    /// Writes a `link_drop` event for every uplink report the link model dropped.
    pub fn uplink(&mut self, k: u64, fates: &[(u32, vbap_mission::link::Fate)]) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        for (v, fate) in fates {
            if let vbap_mission::link::Fate::Drop(reason) = fate {
                self.events.push(&Event {
                    t,
                    k,
                    kind: "link_drop".into(),
                    vehicle: Some(*v),
                    detail: serde_json::json!({ "direction": "uplink", "reason": reason.as_str() }),
                })?;
            }
        }
        Ok(())
    }

    /// Records the arguments of planner step `k` (`planner_inputs.csv`), so `vbap replay`
    /// can re-run the planner offline: `joined` (vehicles admitted back at this tick, each
    /// a member) as rows of role `joined` carrying the member's report.
    pub fn inputs(
        &mut self,
        k: u64,
        members: &[Report],
        fresh: &[Report],
        joined: &[u32],
    ) -> io::Result<()> {
        let same = members == fresh;
        let mut row = |role: &str, q: &Report| {
            self.tracks.input(&InputRow {
                k,
                role,
                id: q.id,
                tick: q.tick,
                position: q.position,
                velocity: q.velocity,
                measurement: q.measurement,
            })
        };
        if same {
            for q in members {
                row("both", q)?;
            }
        } else {
            for q in members {
                row("member", q)?;
            }
            for q in fresh {
                row("fresh", q)?;
            }
        }
        for q in members.iter().filter(|q| joined.contains(&q.id)) {
            row("joined", q)?;
        }
        Ok(())
    }

    /// Counts one tick's messages on the vehicles' own links: the commands of `sizes` and
    /// `reports` reports delivered.
    pub fn links(&mut self, sizes: &crate::near::CommandSizes, reports: u64) {
        let l = &mut self.stats.links;
        l.commands += sizes.count;
        l.command_bytes += sizes.bytes;
        l.command_max = l.command_max.max(sizes.max);
        l.over_limit += sizes.over_limit;
        l.reports += reports;
    }

    /// Records tick `k`: `truth` holds every vehicle's true state and reading (ordered by
    /// id), `told` what each says of itself (the motion columns of `vehicles.csv` when the
    /// mission moves beyond the ideal vehicle), `command` what the planner decided.
    pub fn tick(
        &mut self,
        k: u64,
        truth: &[Report],
        told: &[Told],
        command: &Command,
    ) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        self.vehicle_rows(t, k, truth, told)?;
        let b = &command.body;
        self.body_row(t, k, command)?;
        self.formation_events(t, k, command)?;
        self.scale_held(t, k, b.scale)?;
        self.stats.max_v_over_vu = self
            .stats
            .max_v_over_vu
            .max(command.terms.v / self.mission.body.v_u);
        self.against_optimum(t, k, &b.r)?;
        self.stats.ticks = k + 1;
        self.stats.last_t = t;
        self.stats.last_r = b.r;
        self.stats.last_scale = b.scale;
        Ok(())
    }

    /// The rows of tick `k` (time `t`, s) of `vehicles.csv`: each vehicle's truth, and what
    /// it says of itself (`told`) when the mission moves beyond the ideal vehicle.
    fn vehicle_rows(&mut self, t: f64, k: u64, truth: &[Report], told: &[Told]) -> io::Result<()> {
        let motion = self.mission.moves_beyond_ideal();
        for q in truth {
            let said = told.iter().find(|s| s.id == q.id);
            self.tracks.vehicle(&VehicleRow {
                t,
                k,
                id: q.id,
                position: q.position,
                velocity: q.velocity,
                measurement: q.measurement,
                motion: motion.then(|| {
                    said.map_or((q.position, q.velocity, Vec3::zeros()), |s| {
                        (s.position, s.water, s.current)
                    })
                }),
            })?;
        }
        Ok(())
    }

    /// The row of tick `k` (time `t`, s) of `body.csv`, with the true gradient at the
    /// body's centre.
    fn body_row(&mut self, t: f64, k: u64, command: &Command) -> io::Result<()> {
        let b = &command.body;
        self.tracks.body(&BodyRow {
            t,
            k,
            s: b.s,
            sdot: command.sdot,
            r: b.r,
            scale: b.scale,
            grad: command.grad_est,
            v: command.terms.v,
            n_vehicles: command.members.len(),
            p_trace: command.p_trace,
            true_grad: self.field.gradient(&b.r, t),
        })
    }

    /// The `reconfigured`, `holding` and `resumed` events of tick `k` (time `t`, s), and the
    /// count of holding ticks.
    fn formation_events(&mut self, t: f64, k: u64, command: &Command) -> io::Result<()> {
        if command.reconfigured && k > 0 {
            self.events.push(&Event {
                t,
                k,
                kind: "reconfigured".into(),
                vehicle: None,
                detail: serde_json::json!({ "vehicles": command.members }),
            })?;
        }
        if command.holding != self.stats.was_holding {
            self.stats.was_holding = command.holding;
            self.events.push(&Event {
                t,
                k,
                kind: if command.holding {
                    "holding"
                } else {
                    "resumed"
                }
                .into(),
                vehicle: None,
                detail: serde_json::json!({ "vehicles": command.members.len() }),
            })?;
        }
        if command.holding {
            self.stats.holding_ticks += 1;
        }
        Ok(())
    }

    /// The body's centre `r` of tick `k` (time `t`, s) against the true optimum, when the
    /// field has one: whether the optimum moved, the distance over the last quarter of the
    /// planned ticks, the `converged` event (the first tick within tolerance) and the last
    /// time outside it.
    fn against_optimum(&mut self, t: f64, k: u64, r: &Vec3) -> io::Result<()> {
        let Some(opt) = self.optimum(t) else {
            return Ok(());
        };
        let first = *self.stats.first_optimum.get_or_insert(opt);
        if (opt - first).norm() > 1e-9 * self.mission.mission.tolerance {
            self.stats.optimum_moved = true;
        }
        // The last quarter of the planned ticks.
        if 4 * k >= 3 * self.mission.ticks() {
            let d = (r - opt).norm();
            let tail = &mut self.stats.tail;
            tail.from_t.get_or_insert(t);
            tail.ticks += 1;
            tail.sum += d;
            tail.max = tail.max.max(d);
        }
        if (r - opt).norm() <= self.mission.mission.tolerance {
            if !self.stats.ever_inside {
                self.stats.ever_inside = true;
                self.events.push(&Event {
                    t,
                    k,
                    kind: "converged".into(),
                    vehicle: None,
                    detail: serde_json::json!({ "distance": (r - opt).norm() }),
                })?;
            }
        } else {
            self.stats.last_outside = Some(t);
        }
        Ok(())
    }

    /// Records the true formation of tick `k` (`formation.csv`, `truth.csv`, events):
    /// `truth` the true reports (ordered by id), `command` the planner's decision with
    /// `design` its formation design, `fleet` the coordinator's view after the tick's
    /// deliveries. Call after [`Recorder::tick`].
    pub fn truth(
        &mut self,
        k: u64,
        truth: &[Report],
        command: &Command,
        design: &FormationDesign,
        fleet: &Fleet,
    ) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        let distance = self.optimum(t).map(|o| (command.body.r - o).norm());
        // Diving gliders fly a horizontal formation: judged in its plane.
        let flat: Vec<Report>;
        let truth = if self.mission.diving() {
            let f = |v: Vec3| Vec3::new(v.x, v.y, 0.0);
            flat = truth
                .iter()
                .map(|q| Report {
                    position: f(q.position),
                    velocity: f(q.velocity),
                    ..*q
                })
                .collect();
            &flat
        } else {
            truth
        };
        let out = truth::tick(
            &mut self.stats.truth,
            &self.mission,
            k,
            truth,
            command,
            design,
            fleet,
            distance,
        );
        for row in &out.rows {
            self.truth_files.formation(row)?;
        }
        self.truth_files.truth(&out.row)?;
        for e in &out.events {
            self.events.push(e)?;
        }
        Ok(())
    }

    /// The field's optimum at `t` that the body is judged against: for diving gliders (a
    /// horizontal formation, `Mission::diving`) the point of the surface above it.
    pub(crate) fn optimum(&self, t: f64) -> Option<Vec3> {
        let o = self.field.optimum(t, self.mission.mission.goal)?;
        Some(if self.mission.diving() {
            Vec3::new(o.x, o.y, 0.0)
        } else {
            o
        })
    }

    /// The run directory.
    pub fn dir(&self) -> &RunDir {
        &self.dir
    }

    /// Flushes the files.
    pub fn flush(&mut self) -> io::Result<()> {
        self.tracks.flush()?;
        self.truth_files.flush()?;
        self.events.flush()
    }

    /// Lengths of the appended files once flushed (what a checkpoint covers).
    pub fn offsets(&self) -> vbap_mission::rundir::FileOffsets {
        let (vehicles, body, inputs) = self.tracks.lengths();
        let (formation, truth) = self.truth_files.lengths();
        vbap_mission::rundir::FileOffsets {
            vehicles,
            body,
            inputs,
            events: self.events.len(),
            formation,
            truth,
        }
    }
}
