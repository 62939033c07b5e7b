//! The agent process: wires iceoryx2 ports around [`crate::Vehicle`].
//!
//! Every body command is the lockstep clock (it always arrives, over shared memory);
//! the link model decides when its *content* becomes visible to the vehicle. A
//! (re)started agent that finds a mission under way asks to join (state flag
//! `JOINING`) and waits until the coordinator admits it, then resumes from the state the
//! coordinator hands back.
//!
//! One wake-up per tick: the command arrives, the vehicle steps, publishes its new state
//! and waits again. Its sensor reading is taken by the field server where and when that
//! state says, in the coordinator's batched read of the tick (see
//! `vbap_ipc::msg::coordinator_to_field`).
//!
//! [`run_with`] waits; a `Pilot` (the vehicle, its clock, what it has read and reported)
//! acts on what a wake-up brings: the `CommandFilter` (`run/commands.rs`) reads and checks
//! the body commands, the `Outbox` (`run/outbox.rs`) numbers and publishes the states.

mod commands;
pub mod modem;
mod outbox;

use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use tracing::{info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_ipc::msg::Header;
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics::{self, Domain, Limits};
use vbap_ipc::wait::Wake;
use vbap_math::formation::FormationDesign;
use vbap_math::law::ControlLaw;
use vbap_mission::config::{Mission, Pace};
use vbap_mission::link::{Fate, LinkModel};

use self::commands::{CommandFilter, NewCommand};
use self::modem::Modem;
use self::outbox::{Announce, Outbox};
use crate::{initial_agent, initial_design, Agent, Guidance, Vehicle};

/// Which process of which vehicle an agent is.
#[derive(Clone, Copy, Debug)]
pub struct Start {
    /// The vehicle's id.
    pub id: u32,
    /// The process is a restart (the supervisor says so): it asks to join the mission under
    /// way instead of starting at tick 0.
    pub rejoin: bool,
    /// The process's incarnation in the vehicle's slot (`VehicleState::incarnation`; 0:
    /// unknown).
    pub incarnation: u32,
}

/// Runs the vehicle `start` names of `mission` under the mission's control law
/// ([`crate::mission_law`]) until the mission ends or a termination signal. `msgs` receives
/// the message records; `on_ready` is called once every port exists.
pub fn run(mission: &Mission, start: Start, msgs: MsgLog, on_ready: impl FnOnce()) -> Result<()> {
    run_with(mission, start, crate::mission_law(mission), msgs, on_ready)
}

/// [`run`] with the vehicle flying `law` (a user's own control law).
pub fn run_with(
    mission: &Mission,
    start: Start,
    law: Arc<dyn ControlLaw>,
    msgs: MsgLog,
    on_ready: impl FnOnce(),
) -> Result<()> {
    let Start {
        id, incarnation, ..
    } = start;
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.agent_node(&topics::agent_node_name(id))?;
    let state = domain
        .state_sender(&node, id, &limits)
        .map_err(|e| anyhow::anyhow!("vehicle {id}: cannot publish its state: {e}"))?;
    let body = domain.body_receiver(&node, id, &limits)?;
    let waiter = body.wake().attach()?;
    let modem = match mission.acoustic {
        Some(_) => Some(Modem::open(&domain, &node, id, &limits)?),
        None => None,
    };

    let mut pilot = Pilot::new(
        mission,
        start,
        law,
        Outbox::new(state, id, incarnation, mission.mission.dt),
        msgs,
    )?;
    pilot.modem = modem;
    info!(
        vehicle = id,
        joining = pilot.joining,
        tick = pilot.k,
        x = pilot.vehicle.agent.position.x,
        y = pilot.vehicle.agent.position.y,
        z = pilot.vehicle.agent.position.z,
        "agent up"
    );
    on_ready();
    if pilot.joining {
        pilot.ask_to_join()?;
    } else {
        pilot.out.publish(&pilot.vehicle, 0, 0, 0, Announce::Now)?;
    }

    // Check for commands first, wait only when there is nothing to act on.
    let mut idle = false;
    loop {
        if idle {
            // Lockstep: a deadline as a safety net, so a lost wake-up costs a second, not the
            // mission (on a timeout the body subscriber is read once).
            let timeout = pilot.hold_after.unwrap_or(Duration::from_secs(1));
            // The records so far reach the file before every wait (at least once a tick):
            // a SIGKILL loses at most those of the tick under way.
            pilot.msgs.flush();
            pilot.out.announce()?;
            match waiter.wait(timeout, |_| {})? {
                Wake::Stop => {
                    info!(vehicle = id, tick = pilot.k, "stopped by signal");
                    return Ok(());
                }
                Wake::Timeout if pilot.may_hold_station() => {
                    pilot.hold_station()?;
                    continue;
                }
                Wake::Timeout | Wake::Events => {}
            }
        }
        let drained = pilot.filter.drain(&body, &mut pilot.msgs)?;
        if drained.finished {
            pilot.finish(drained.commands);
            return Ok(());
        }
        // Whatever else this drain read: an agent that ran ahead (a submerged glider) may
        // read the dead coordinator's last command and its re-sent copy together, and the
        // states it published past that command died with the coordinator that read them.
        if let Some(after) = drained.resend_after {
            pilot.resend_after(after)?;
        }
        pilot.listen()?;
        let stepped = pilot.apply(drained.commands)?;
        let ran_ahead = pilot.lockstep_step()?;
        idle = !(stepped || ran_ahead);
        pilot.log_fates();
        if pilot.joining && pilot.asked.elapsed() >= JOIN_AGAIN {
            // Not admitted yet: the request may have been lost (a coordinator that was
            // down, or restarted and has not read it): asked again, until admitted.
            pilot.ask_to_join()?;
        }
    }
}

/// How often a joining agent asks again while it is not admitted (wall time; it also asks
/// again at once when a restarted coordinator re-sends its last command). A request is
/// one message, and a coordinator that was down, or restarted, may never have read it.
const JOIN_AGAIN: Duration = Duration::from_millis(200);

/// One vehicle agent between two waits: the vehicle, its clock and what it has read and
/// reported.
struct Pilot<'m> {
    mission: &'m Mission,
    id: u32,
    dt: f64,
    ticks: u64,
    model: LinkModel,
    /// The formation design of the start ([`Guidance::restarted`] takes its potentials).
    design: FormationDesign,
    law: Arc<dyn ControlLaw>,
    /// The mission's motion beyond the ideal vehicle (None: the paper's vehicle).
    kin: Option<Arc<crate::motion::Kinematics>>,
    vehicle: Vehicle,
    /// Paced runs hold station when the coordinator is silent this long (lockstep: None).
    hold_after: Option<Duration>,
    /// A restarted process waits to be admitted back.
    joining: bool,
    /// This process's incarnation (`VehicleState::incarnation`; 0: unknown): only an
    /// admission naming it (or 0) is ours.
    incarnation: u32,
    /// When the last join request went out.
    asked: std::time::Instant,
    /// The vehicle's tick: its state is that of t = k·dt.
    k: u64,
    /// Lockstep: the newest command received bounds how far the vehicle may run ahead.
    newest_command: Option<u64>,
    /// The commands read as last reported to the coordinator.
    reported_read: u64,
    filter: CommandFilter,
    out: Outbox,
    msgs: MsgLog,
    /// The acoustic modem (`[acoustic]`; None without).
    modem: Option<Modem>,
    /// Since when the next step has waited for acoustic frames.
    waiting_frames: Option<std::time::Instant>,
}

/// How long a lockstep agent waits for another vehicle's acoustic frames before it steps
/// without them (wall time): far above any scheduling delay of a live sender, short
/// against a mission.
const FRAME_PATIENCE: Duration = Duration::from_secs(2);

impl<'m> Pilot<'m> {
    fn new(
        mission: &'m Mission,
        Start {
            id,
            rejoin,
            incarnation,
        }: Start,
        law: Arc<dyn ControlLaw>,
        out: Outbox,
        msgs: MsgLog,
    ) -> Result<Self> {
        let dt = mission.mission.dt;
        let design = initial_design(mission).context("initial formation design")?;
        let initial = Guidance::initial(mission, &design);
        let kin = crate::motion::Kinematics::of(mission);
        let vehicle = Vehicle::new(initial_agent(mission, &design, id), initial, 0)
            .with_law(law.clone())
            .with_motion(kin.clone(), dt)
            .with_acoustic(
                vbap_mission::acoustic::AcousticModel::new(mission),
                mission.control.neighbour_memory,
                msgs.is_enabled(),
            );
        Ok(Self {
            mission,
            id,
            dt,
            ticks: mission.ticks(),
            model: LinkModel::new(mission),
            design,
            law,
            kin,
            vehicle,
            hold_after: match mission.mission.pace {
                Pace::Lockstep => None,
                Pace::Factor(f) => Some(Duration::from_secs_f64((4.0 * dt / f).max(0.5))),
            },
            // A restarted process asks to join the mission under way; the coordinator
            // admits it by handing its last known state back in the snapshot.
            joining: rejoin,
            incarnation,
            asked: std::time::Instant::now(),
            k: 0,
            newest_command: None,
            reported_read: 0,
            filter: CommandFilter::new(
                id,
                mission.body.v0,
                vbap_mission::horizon::plan_horizon(&mission.links, mission.mission.dt),
                vbap_ipc::compact::Precision::of_quantum(mission.links.position_quantum),
            ),
            out,
            msgs,
            modem: None,
            waiting_frames: None,
        })
    }

    /// Reads the acoustic frames that came in (`[acoustic]`). Not while joining: the
    /// frames wait in the buffer for the receiver of the vehicle admitted back (those of
    /// its admission tick may come with the command that admits it).
    fn listen(&mut self) -> Result<()> {
        match &mut self.modem {
            Some(m) if !self.joining => m.drain(&mut self.vehicle),
            _ => Ok(()),
        }
    }

    /// The vehicle has reached the state of tick `self.k`: its acoustic frames of the tick
    /// go out, before the state itself (a step of another vehicle that needs them waits for
    /// a command the coordinator publishes only once it has this state).
    fn transmit(&mut self) -> Result<()> {
        match &mut self.modem {
            Some(m) => m.transmit(&mut self.vehicle, self.k),
            None => Ok(()),
        }
    }

    /// On an acoustic mission the step from tick `k` needs every frame sent before t_k by
    /// the schedule (`Ear::missing`); their senders wake this agent as they send them. A
    /// sender whose frames do not come for [`FRAME_PATIENCE`] (its process died without a
    /// scheduled fault: `vbap chaos`) is given up for those ticks, with a warning.
    fn frames_in(&mut self, k: u64) -> bool {
        if self.modem.is_some() && self.newest_command.is_none() {
            // No frame before the first command: the coordinator publishes it once every
            // agent has said it is up, its acoustic subscriber open.
            return false;
        }
        let Some(ear) = self.vehicle.ear_mut() else {
            return true;
        };
        loop {
            let Some(sender) = ear.missing(k) else {
                self.waiting_frames = None;
                return true;
            };
            let since = *self
                .waiting_frames
                .get_or_insert_with(std::time::Instant::now);
            if since.elapsed() < FRAME_PATIENCE {
                return false;
            }
            warn!(
                vehicle = self.id,
                sender,
                tick = k,
                "acoustic frames never came: stepping without them"
            );
            ear.give_up(sender, k);
            self.waiting_frames = None;
        }
    }

    /// The commands read so far (`VehicleState::commands_read`).
    fn read(&self) -> u64 {
        self.newest_command.map_or(0, |c| c + 1)
    }

    /// A paced run with nothing heard may hold station; only once the mission is under
    /// way: before its first command a vehicle waits where it was deployed (the set may
    /// still be starting up).
    fn may_hold_station(&self) -> bool {
        self.hold_after.is_some() && !self.joining && self.filter.last_seq.is_some()
    }

    /// Nothing heard (paced runs): one step flying the last visible guidance.
    fn hold_station(&mut self) -> Result<()> {
        self.vehicle.hold_station(self.k, self.dt);
        self.k += 1;
        self.transmit()?;
        warn!(
            vehicle = self.id,
            tick = self.k,
            "coordinator silent: holding station"
        );
        self.out.publish(
            &self.vehicle,
            self.k,
            VehicleState::HOLDING,
            self.read(),
            Announce::Now,
        )
    }

    /// The end of the mission. Commands read in the same drain as the end (a slow agent
    /// finds both in its buffer) still had their link fates: draw them (up to the newest,
    /// in order), so the downlink counts equal the simulator's, which draws every
    /// command's.
    fn finish(&mut self, mut commands: Vec<NewCommand>) {
        if !self.joining {
            if let Some((tick, guidance, _, bytes)) = commands.pop() {
                self.vehicle
                    .receive(&self.model, guidance, bytes, tick, self.dt);
            }
            // The simulator steps from the last tick too: its receiver decides the frames
            // that ended by then; so does this one (its step would change nothing recorded).
            let _ = self.listen();
            let (k, truth) = (self.k, self.vehicle.agent.position);
            if let Some(ear) = self.vehicle.ear_mut() {
                ear.track(k, truth);
                ear.decide(k);
            }
        }
        self.log_fates();
        info!(
            vehicle = self.id,
            tick = self.k,
            rejected = self.filter.rejected,
            delivered = self.vehicle.counts.delivered,
            dropped = self.vehicle.counts.dropped,
            "mission finished"
        );
    }

    /// Asks to join the mission under way (a state flagged `JOINING`: the vehicle as it was
    /// deployed, this process's pid and incarnation).
    fn ask_to_join(&mut self) -> Result<()> {
        self.asked = std::time::Instant::now();
        self.out
            .publish(&self.vehicle, 0, VehicleState::JOINING, 0, Announce::Now)
    }

    /// Whether `own` (this vehicle's entry of a command's snapshot) admits this process:
    /// flagged [`SnapshotEntry::ADMITTED`] for this incarnation (or an unknown one). An
    /// admission of an earlier process of the vehicle (read from the body service's
    /// history by a process restarted at once) is not ours.
    fn admits_me(&self, own: Option<&SnapshotEntry>) -> bool {
        own.is_some_and(|e| {
            e.alive == SnapshotEntry::ADMITTED
                && (e.incarnation == 0
                    || self.incarnation == 0
                    || e.incarnation == self.incarnation)
        })
    }

    /// A restarted coordinator re-sent its last command (of tick `after`): our states
    /// since, again (a joining process: its request).
    fn resend_after(&mut self, after: u64) -> Result<()> {
        if self.joining {
            return self.ask_to_join();
        }
        for tick in self.out.resend_after(after, self.read())? {
            info!(
                vehicle = self.id,
                tick, "re-sent a state to a restarted coordinator"
            );
        }
        Ok(())
    }

    /// Takes the new commands in: admission of a joining vehicle, the link's verdicts, and
    /// in a paced run a step on each. True when the vehicle stepped.
    fn apply(&mut self, mut commands: Vec<NewCommand>) -> Result<bool> {
        let paced = self.hold_after.is_some();
        if paced && commands.len() > 1 {
            // Paced: only the newest command counts (the older ones are late), but a
            // joining vehicle never skips the one that admits it.
            let admission = commands
                .iter()
                .rposition(|(_, _, own, _)| self.joining && self.admits_me(own.as_ref()));
            commands.drain(..admission.unwrap_or(commands.len() - 1));
        }
        let mut stepped = false;
        for (tick, guidance, own, bytes) in commands {
            self.newest_command = Some(tick);
            let admitted = self.admits_me(own.as_ref());
            if self.joining || admitted {
                // Admitted when the coordinator hands our state back in the snapshot.
                match own {
                    Some(e) if admitted => self.admit(&e, tick),
                    _ => continue,
                }
            } else if paced {
                if tick < self.k {
                    continue; // an old command (paced runs): we already stepped past it
                }
                self.k = tick;
            }
            self.vehicle
                .receive(&self.model, guidance, bytes, tick, self.dt);
            if paced {
                // Paced: step on every command, from its tick (late ones are skipped).
                self.vehicle.forget_before(tick);
                self.vehicle.step(self.k, self.dt);
                self.k += 1;
                stepped = true;
                self.transmit()?;
                if self.k < self.ticks {
                    self.out
                        .publish(&self.vehicle, self.k, 0, self.read(), Announce::Now)?;
                    self.reported_read = self.read();
                }
            }
        }
        Ok(stepped)
    }

    /// Admitted back at tick `tick` from the state of snapshot entry `e`.
    fn admit(&mut self, e: &SnapshotEntry, tick: u64) {
        let agent = Agent {
            id: self.id,
            dim: self.mission.mission.dim,
            position: vbap_ipc::msg::to_vec3(&e.position),
            velocity: vbap_ipc::msg::to_vec3(&e.velocity),
        };
        self.vehicle = Vehicle::new(
            agent,
            Guidance::restarted(self.mission, &self.design, tick),
            tick,
        )
        .with_law(self.law.clone())
        .with_motion(self.kin.clone(), self.dt)
        .with_acoustic(
            vbap_mission::acoustic::AcousticModel::new(self.mission),
            self.mission.control.neighbour_memory,
            self.msgs.is_enabled(),
        );
        self.joining = false;
        self.k = tick;
        if let Some(m) = &mut self.modem {
            m.rejoined();
        }
        info!(vehicle = self.id, tick, "admitted back into the formation");
    }

    /// Lockstep: steps whenever every command the step needs is in; a submerged glider (or
    /// a long link delay) needs none, and runs ahead (up to `Limits::LOOKAHEAD_TICKS`).
    /// Otherwise, still reading commands, says so. True when the vehicle stepped.
    fn lockstep_step(&mut self) -> Result<bool> {
        if self.hold_after.is_some() || self.joining {
            return Ok(false);
        }
        let limit = self.read() + Limits::LOOKAHEAD_TICKS;
        let k = self.k;
        if k + 1 < self.ticks
            && k < limit
            && self.frames_in(k)
            && self.vehicle.ready_to_step(&self.model, k, self.dt)
        {
            self.vehicle.step(k, self.dt);
            self.k += 1;
            self.transmit()?;
            // The state of the tick the coordinator gathers now (or next) wakes it; ahead of
            // it, it is woken once, before we next wait.
            let announce = if self.k <= self.read() + 1 {
                Announce::Now
            } else {
                Announce::BeforeNextWait
            };
            self.out
                .publish(&self.vehicle, self.k, 0, self.read(), announce)?;
            self.reported_read = self.read();
            return Ok(true);
        }
        if self.read() >= self.reported_read + 2 && self.out.acknowledge(self.read())? {
            // Waiting, but still reading commands: said so, so the coordinator may go on
            // publishing without overflowing our command buffer.
            self.reported_read = self.read();
        }
        Ok(false)
    }

    /// The link model's verdicts on commands and the acoustic receiver's on frames, for
    /// the message records.
    fn log_fates(&mut self) {
        modem::log_verdicts(&mut self.vehicle, &mut self.msgs);
        for (tick, fate) in self.vehicle.take_drawn() {
            match fate {
                Fate::Deliver { injected, .. } if injected > 0.0 => {
                    self.msgs
                        .held("body", Header::COORDINATOR, self.id, tick, injected)
                }
                Fate::Drop(reason) => {
                    self.msgs
                        .drop("body", Header::COORDINATOR, self.id, tick, reason.as_str())
                }
                _ => {}
            }
        }
    }
}
