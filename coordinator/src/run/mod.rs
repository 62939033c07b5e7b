//! The coordinator process: gathers states, reads the tick's sensors through the field
//! server (one batched request), applies the link model, detects lost and returning
//! vehicles, applies scheduled kills, steps the planner, publishes the body.
//!
//! A tick, in order ([`Coordinator::tick`]): scheduled kills and restarts
//! ([`faults`]), unscheduled returns, the gathering of the tick's states with the liveness
//! checks of the vehicles still missing ([`gather`], [`liveness`]), their sensor
//! readings ([`sensors`]), the planner's step through [`crate::tick::plan_tick`], the
//! checkpoint and the publication of the command ([`publish`]). The ports are opened in
//! [`ports`]; a restarted coordinator resumes from its checkpoint ([`resume`]).

mod faults;
mod gather;
mod inbox;
mod liveness;
mod ports;
mod publish;
mod resume;
mod sensors;

use std::collections::BTreeSet;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use anyhow::Result;
use serde::de::DeserializeOwned;
use serde::Serialize;
use tracing::{info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::{to_vec3, wall_ns};
use vbap_ipc::msglog::MsgLog;
use vbap_mission::config::Mission;
use vbap_mission::faults::FaultPlan;
use vbap_mission::rundir::{RunDir, Summary};

use crate::checkpoint::CheckpointWriter;
use crate::fleet::Fleet;
use crate::plan::Plan;
use crate::planner::{Planner, PlannerError, PlannerParams, Report, Told};
use crate::record::Recorder;
use inbox::Inbox;
use liveness::Liveness;
use ports::Ports;
use resume::Setup;
use sensors::SensorReads;
use std::sync::Arc;
use vbap_ipc::msg::coordinator_to_field::SampleBatch;
use vbap_mission::field::ScalarField;

/// Wall time a lockstep tick waits for a silent vehicle before going on without it (a
/// vehicle heard from before is then lost as `silent`: see [`liveness`]).
pub const LOCKSTEP_TIMEOUT: Duration = Duration::from_secs(10);

/// A tick goes on, or a termination signal stops the mission.
type Flow = ControlFlow<()>;
const GO: Flow = ControlFlow::Continue(());
const STOP: Flow = ControlFlow::Break(());

/// Runs the coordinator of `mission` with the paper's planner, writing into `dir`. `msgs`
/// receives the message records; `on_ready` is called once every port exists. Returns the
/// summary of the run (for the caller to write: see `summary.json`) when the mission is
/// over or on a termination signal.
pub fn run(
    mission: &Mission,
    dir: &RunDir,
    msgs: MsgLog,
    on_ready: impl FnOnce(),
) -> Result<Summary> {
    run_with(
        mission,
        dir,
        msgs,
        on_ready,
        Arc::new(mission.field()),
        |ids| {
            Planner::new(
                PlannerParams::from_mission(mission),
                mission.start_vec(),
                ids,
            )
        },
    )
}

/// [`run`] with any planner: `new_planner` makes the planner of a new run for the vehicles
/// it is given; a restarted coordinator takes the one of its checkpoint instead.
pub fn run_with<P: Plan + Serialize + DeserializeOwned>(
    mission: &Mission,
    dir: &RunDir,
    msgs: MsgLog,
    on_ready: impl FnOnce(),
    truth: Arc<dyn ScalarField>,
    new_planner: impl FnOnce(&[u32]) -> Result<P, PlannerError>,
) -> Result<Summary> {
    let opened = Ports::open(mission)?;
    let _guard = opened.ports.attach()?;
    let (mut c, republish) = Coordinator::start(
        mission,
        dir,
        &opened.ports,
        SensorReads::new(
            opened.sample.0,
            opened.sample.1,
            Box::new(SampleBatch::empty()),
        ),
        Liveness::new(opened.exits, dir.root.clone()),
        Setup {
            msgs,
            truth,
            new_planner,
        },
    )?;
    info!(
        vehicles = mission.vehicles.count,
        ticks = mission.ticks(),
        start_tick = c.k,
        "coordinator up"
    );
    on_ready();
    if let Some(record) = republish {
        c.publish(&record)?;
    }
    let mut stopped = false;
    while c.k < mission.ticks() {
        if c.tick()?.is_break() {
            stopped = true;
            break;
        }
    }
    if !stopped {
        stopped = c.await_room_for_the_end()?.is_break();
    }
    c.finish(stopped)
}

/// Counters and latencies of `summary.json` the process keeps (checkpointed).
#[derive(Default)]
struct Books {
    /// Wall ms from each death to its detection.
    detection_ms: Vec<f64>,
    /// Wall ms from each join request to the admission.
    rejoin_ms: Vec<f64>,
    /// Paced ticks that were late.
    late_ticks: u64,
    /// Body commands published.
    sent: u64,
}

/// The wall clock of a paced mission: when its tick 0 was due (kept across restarts).
#[derive(Default)]
struct MissionClock {
    start: Option<Instant>,
    /// The same, ns since the Unix epoch (checkpointed).
    start_ns: Option<u64>,
}

impl MissionClock {
    /// When tick 0 was due; set now when not yet.
    fn start(&mut self) -> Instant {
        *self.start.get_or_insert_with(|| {
            self.start_ns = Some(wall_ns());
            Instant::now()
        })
    }
}

/// The coordinator process's whole state between ticks.
struct Coordinator<'a, P> {
    mission: &'a Mission,
    dt: f64,
    /// The tick period in wall seconds of a paced mission; None in lockstep.
    paced: Option<f64>,
    ports: &'a Ports,
    sensors: SensorReads,
    live: Liveness,
    inbox: Inbox,
    faults: FaultPlan,
    fleet: Fleet,
    planner: P,
    recorder: Recorder,
    books: Books,
    clock: MissionClock,
    /// None when the coordinator is never restarted (no checkpoint needed).
    checkpoints: Option<CheckpointWriter>,
    /// The reused buffer of the body command.
    body: Box<BodyCommand>,
    /// The tick under way.
    k: u64,
}

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// One tick: faults, returns, the states and their readings, the planner's step, the
    /// command. [`STOP`] on a termination signal.
    fn tick(&mut self) -> Result<Flow> {
        self.recorder.faults_starting(self.k)?;
        if self.scheduled_kills()?.is_break() || self.scheduled_restarts()?.is_break() {
            return Ok(STOP);
        }
        self.admit_returns()?;
        // Vehicles admitted at this tick are members at their restore state: no state of
        // theirs is waited for.
        let admitted: BTreeSet<u32> = self.fleet.admitted().iter().map(|r| r.id).collect();
        if self.gather(&admitted)?.is_break() {
            return Ok(STOP);
        }
        let Some((truth, told)) = self.readings(&admitted)? else {
            return Ok(STOP);
        };
        let record = self.plan(&truth, &told)?;
        self.fleet.end_tick();
        self.checkpoint(&record)?;
        self.publish(&record)?;
        self.books.sent += 1;
        self.k += 1;
        Ok(GO)
    }

    /// The states of the tick (ordered by id) with their sensor readings, fetched in one
    /// batched read, as the true reports of the tick (a state whose read the field server
    /// rejected is dropped). In lockstep, the readings of the states of later ticks already
    /// in are asked for meanwhile. With them what each vehicle says of itself (its belief,
    /// water velocity and current). None on a termination signal.
    #[allow(clippy::type_complexity)]
    fn readings(&mut self, admitted: &BTreeSet<u32>) -> Result<Option<(Vec<Report>, Vec<Told>)>> {
        let k = self.k;
        let paced = self.paced.is_some();
        let mut states: Vec<VehicleState> = self
            .fleet
            .alive()
            .filter(|v| !admitted.contains(v))
            .filter_map(|v| self.inbox.state(v, k, paced).copied())
            .collect();
        // A paced tick does not wait for a field server that owes its answer longer than
        // READINGS_GRACE: the states without their reading are dropped below.
        let grace = paced.then_some(sensors::READINGS_GRACE);
        loop {
            let waited = self.sensors.wait_for(
                k,
                self.dt,
                &states,
                grace,
                self.ports,
                &mut self.inbox.msgs,
                &mut self.live,
            )?;
            match waited {
                None => return Ok(None),
                Some(sensors::Waited::Done) => break,
                // A death reported while the field server is slow, stopped or restarting
                // (lockstep waits for every reading) is decided now, at this tick, not
                // when the field server answers.
                Some(sensors::Waited::Deaths) => {
                    if self.supervisor_reports()? {
                        states.retain(|s| self.fleet.is_alive(s.header.sender));
                    }
                }
            }
        }
        if !paced && self.sensors.idle() {
            let ahead = self.read_ahead(admitted);
            self.sensors.request(k, self.dt, &ahead)?;
        }
        let mut truth: Vec<Report> = Vec::with_capacity(states.len());
        let mut told: Vec<Told> = Vec::with_capacity(states.len());
        for s in &states {
            if !self.sensors.has(s) {
                continue; // paced, the field server silent: as a state late at the deadline
            }
            let Some(measurement) = self.sensors.take(s) else {
                self.inbox.counts.rejected += 1;
                warn!(
                    vehicle = s.header.sender,
                    tick = s.header.tick,
                    "the field server rejected this vehicle's sensor read: state dropped"
                );
                continue;
            };
            truth.push(Report {
                id: s.header.sender,
                tick: s.header.tick,
                position: to_vec3(&s.position),
                velocity: to_vec3(&s.velocity),
                measurement,
            });
            told.push(Told {
                id: s.header.sender,
                position: to_vec3(&s.believed),
                water: to_vec3(&s.water_velocity),
                current: to_vec3(&s.current),
            });
        }
        self.inbox.used(k, paced);
        // Readings of states that will never be used (their vehicle was lost).
        self.sensors.forget_through(k);
        Ok(Some((truth, told)))
    }

    /// The states of later ticks already in whose readings are not, in tick order, for a
    /// read-ahead (not past a vehicle's scheduled kill: its sensor is never read then).
    fn read_ahead(&self, admitted: &BTreeSet<u32>) -> Vec<VehicleState> {
        let k = self.k;
        let mut ahead: Vec<VehicleState> =
            self.fleet
                .alive()
                .filter(|v| !admitted.contains(v))
                .filter_map(|v| {
                    let from = self.sensors.unread_from(v, k + 1);
                    Some(self.inbox.states.get(&v)?.range(from..).map(|(_, s)| *s))
                })
                .flatten()
                .filter(|s| {
                    !self.faults.kills.iter().any(|x| {
                        x.vehicle == s.header.sender && x.tick > k && x.tick <= s.header.tick
                    })
                })
                .collect();
        ahead.sort_by_key(|s| (s.header.tick, s.header.sender));
        ahead
    }
}
