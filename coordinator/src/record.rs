//! Turns ticks into the run-directory files and the summary (DESIGN §8).
//!
//! The recorder is the omniscient logger of a simulator: it knows the true field and the
//! true optimum, which the planner never sees. The in-process simulator and the
//! coordinator process both use it, so their files are written by the same code.

use std::io;

use shared::config::Mission;
use shared::field::Field;
use shared::math::convergence::theorem_5_1_bound;
use shared::math::Vec3;
use shared::plot::{MissionPlot, Snapshot, Track};
use shared::rundir::{
    BodyRow, Event, EventLog, InputRow, RunDir, Summary, TrackWriter, VehicleRow,
};

use crate::planner::{Command, Planner, Report};

/// Number of formation snapshots drawn on the plot.
const PLOT_SNAPSHOTS: usize = 6;
/// Track points kept per vehicle for the plot (downsampled evenly).
const PLOT_POINTS: usize = 2000;

/// Records ticks, accumulates the figures of `summary.json`.
pub struct Recorder {
    mission: Mission,
    field: Field,
    dir: RunDir,
    tracks: TrackWriter,
    events: EventLog,
    stride: u64,
    plot_tracks: std::collections::BTreeMap<u32, Vec<(f64, f64)>>,
    plot_body: Vec<(f64, f64)>,
    plot_snapshots: Vec<Snapshot>,
    max_v_over_vu: f64,
    last_outside: Option<f64>,
    ever_inside: bool,
    holding_ticks: u64,
    ticks: u64,
    last_t: f64,
    last_r: Vec3,
    last_scale: f64,
    vehicles_started: usize,
    vehicles_lost: usize,
    vehicles_rejoined: usize,
    was_holding: bool,
}

impl Recorder {
    /// Opens the CSV and event files of `dir` (appending).
    pub fn open(mission: &Mission, dir: &RunDir) -> io::Result<Self> {
        let ticks = mission.ticks().max(1);
        Ok(Self {
            mission: mission.clone(),
            field: mission.field(),
            dir: dir.clone(),
            tracks: TrackWriter::open(dir)?,
            events: EventLog::open(dir)?,
            stride: (ticks / PLOT_POINTS as u64).max(1),
            plot_tracks: Default::default(),
            plot_body: Vec::new(),
            plot_snapshots: Vec::new(),
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
        })
    }

    /// Appends an event to `events.jsonl`.
    pub fn event(&mut self, e: Event) -> io::Result<()> {
        match e.kind.as_str() {
            "lost" => self.vehicles_lost += 1,
            "rejoin" => self.vehicles_rejoined += 1,
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
            .filter(|f| shared::faults::tick_at(f.at, dt) == k)
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

    /// Vehicle `v` was lost at tick `k` (`cause`: "scheduled kill", "process died", ...).
    pub fn lost(&mut self, k: u64, v: u32, cause: &str) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        self.event(Event {
            t,
            k,
            kind: "lost".into(),
            vehicle: Some(v),
            detail: serde_json::json!({ "cause": cause }),
        })
    }

    /// Vehicle `v` was admitted back at tick `k`.
    pub fn rejoined(&mut self, k: u64, v: u32) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        self.event(Event {
            t,
            k,
            kind: "rejoin".into(),
            vehicle: Some(v),
            detail: serde_json::Value::Null,
        })
    }

    /// Writes a `link_drop` event for every uplink report the link model dropped.
    pub fn uplink(&mut self, k: u64, fates: &[(u32, shared::link::Fate)]) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        for (v, fate) in fates {
            if let shared::link::Fate::Drop(reason) = fate {
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
    /// can re-run the planner offline.
    pub fn inputs(&mut self, k: u64, members: &[Report], fresh: &[Report]) -> io::Result<()> {
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
        Ok(())
    }

    /// Records tick `k`: `truth` holds every vehicle's true state and reading (ordered by
    /// id), `command` what the planner decided.
    pub fn tick(&mut self, k: u64, truth: &[Report], command: &Command) -> io::Result<()> {
        let t = k as f64 * self.mission.mission.dt;
        for q in truth {
            self.tracks.vehicle(&VehicleRow {
                t,
                k,
                id: q.id,
                position: q.position,
                velocity: q.velocity,
                measurement: q.measurement,
            })?;
        }
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
        })?;
        if command.reconfigured && k > 0 {
            self.events.push(&Event {
                t,
                k,
                kind: "reconfigured".into(),
                vehicle: None,
                detail: serde_json::json!({ "vehicles": command.members }),
            })?;
        }
        if command.holding != self.was_holding {
            self.was_holding = command.holding;
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
            self.holding_ticks += 1;
        }
        self.max_v_over_vu = self
            .max_v_over_vu
            .max(command.terms.v / self.mission.body.v_u);
        if let Some(opt) = self.field.optimum(t, self.mission.mission.goal) {
            if (b.r - opt).norm() <= self.mission.mission.tolerance {
                if !self.ever_inside {
                    self.ever_inside = true;
                    self.events.push(&Event {
                        t,
                        k,
                        kind: "converged".into(),
                        vehicle: None,
                        detail: serde_json::json!({ "distance": (b.r - opt).norm() }),
                    })?;
                }
            } else {
                self.last_outside = Some(t);
            }
        }
        if k.is_multiple_of(self.stride) {
            for q in truth {
                self.plot_tracks
                    .entry(q.id)
                    .or_default()
                    .push((q.position.x, q.position.y));
            }
            self.plot_body.push((b.r.x, b.r.y));
        }
        let total = self.mission.ticks().max(1);
        let every = (total / PLOT_SNAPSHOTS as u64).max(1);
        if k.is_multiple_of(every) || k + 1 == total {
            self.plot_snapshots.push(Snapshot {
                t,
                positions: truth.iter().map(|q| (q.position.x, q.position.y)).collect(),
                centre: (b.r.x, b.r.y),
            });
        }
        self.ticks = k + 1;
        self.last_t = t;
        self.last_r = b.r;
        self.last_scale = b.scale;
        Ok(())
    }

    /// Flushes the files.
    pub fn flush(&mut self) -> io::Result<()> {
        self.tracks.flush()?;
        self.events.flush()
    }

    /// The mission figures of `summary.json` (message counts, latency and wall time are
    /// filled in by the caller).
    pub fn summary(&self, planner: &Planner, mode: &str) -> Summary {
        let m = &self.mission;
        let t = self.last_t;
        let r = self.last_r;
        let optimum = self.field.optimum(t, m.mission.goal);
        let distance = optimum.map(|o| (r - o).norm());
        let converged = distance.is_some_and(|d| d <= m.mission.tolerance);
        let time_to_converge_s = if converged {
            Some(self.last_outside.map_or(0.0, |t_out| t_out + m.mission.dt))
        } else {
            None
        };
        let final_grad_norm = self.field.gradient(&r, t).norm();
        let bound = planner.filter().and_then(|f| {
            theorem_5_1_bound(
                m.estimator.confidence,
                &f.covariance(),
                m.mission.dim,
                m.estimator.delta_m,
            )
            .ok()
        });
        Summary {
            mission: m.mission.name.clone(),
            mode: mode.to_string(),
            seed: m.mission.seed,
            converged,
            final_distance_to_optimum: distance,
            final_grad_norm,
            theorem_5_1_bound: bound,
            in_set_m: bound.map(|b| final_grad_norm <= b),
            time_to_converge_s,
            vehicles_started: self.vehicles_started,
            vehicles_lost: self.vehicles_lost,
            vehicles_rejoined: self.vehicles_rejoined,
            reconfigurations: planner.reconfigurations(),
            max_v_over_vu: self.max_v_over_vu,
            ticks: self.ticks,
            final_time_s: t,
            final_body_position: [r.x, r.y, r.z],
            final_scale: self.last_scale,
            optimum: optimum.map(|o| [o.x, o.y, o.z]),
            estimated_sigma_m: Some(planner.sigma_m()),
            holding_ticks: self.holding_ticks,
            ..Summary::default()
        }
    }

    /// Writes `plot.svg`: tracks on the field's contours, the body path, formation
    /// snapshots and the optimum.
    pub fn write_plot(&self) -> Result<(), shared::plot::PlotError> {
        let m = &self.mission;
        let t = self.last_t;
        let field = &self.field;
        let z = if m.mission.dim == 3 {
            self.last_r.z
        } else {
            0.0
        };
        let sample = move |x: f64, y: f64| field.value(&Vec3::new(x, y, z), t);
        let optimum = field.optimum(t, m.mission.goal).map(|o| (o.x, o.y));
        let plot = MissionPlot {
            title: format!("{} (seed {})", m.mission.name, m.mission.seed),
            length_unit: m.mission.length_unit.clone(),
            field: &sample,
            field_label: m.mission.field_label.clone(),
            tracks: self
                .plot_tracks
                .iter()
                .map(|(id, pts)| Track {
                    id: *id,
                    points: pts.clone(),
                })
                .collect(),
            body_path: self.plot_body.clone(),
            snapshots: self.plot_snapshots.clone(),
            optimum,
            events: Vec::new(),
        };
        shared::plot::write_mission_svg(&plot, &self.dir.plot())
    }
}
