//! The vehicle agent: one process per vehicle (`vehicle_agent --id I`).
//!
//! [`Agent::step`] is the whole decision of a tick and never sees iceoryx2: it computes
//! u_i from (II.1) with the latest virtual leaders and neighbour states the agent has
//! received, and integrates the double integrator ẍ_i = u_i. The in-process simulator
//! calls exactly this function, which is why the multi-process system can reproduce it
//! bit for bit. [`run`] wires the ports.

pub mod cli;
pub mod motion;
pub mod run;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::Rng;
use vbap_math::body::VirtualBody;
use vbap_math::control::integrate;
use vbap_math::formation::FormationDesign;
pub use vbap_math::law::{ControlInputs, ControlLaw, PaperLaw, RobustLaw};
use vbap_math::potential::PairPotential;
use vbap_math::rejoin::{homing_weight, Homing};
use vbap_math::rng::{keyed, Stream};
use vbap_math::schedule::{BodyPlan, BodySchedule};
use vbap_math::Vec3;
use vbap_mission::config::{LawKind, Mission};
use vbap_mission::link::{DelayQueue, Direction, Fate, LinkModel, LinkState};

/// What an agent needs from the coordinator for one step (the inputs of a
/// [`ControlLaw`]).
pub type AgentInputs<'a> = ControlInputs<'a>;

/// One vehicle: its own state and dynamics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agent {
    /// Vehicle id.
    pub id: u32,
    /// Mission dimension (2 or 3); in 2-D z stays 0.
    pub dim: usize,
    /// Position x_i, length unit.
    pub position: Vec3,
    /// Velocity ẋ_i, length unit/s.
    pub velocity: Vec3,
}

impl Agent {
    /// One control step of length `dt` (s) under the paper's law ([`PaperLaw`]): u_i from
    /// (II.1) — blended with the homing law of `vbap_math::rejoin` while this vehicle or
    /// a neighbour rejoins — then ẍ_i = u_i integrated (semi-implicit Euler). Returns u_i.
    pub fn step(&mut self, inputs: &AgentInputs<'_>, dt: f64) -> Vec3 {
        self.step_with(&PaperLaw, inputs, dt)
    }

    /// One control step of length `dt` (s) under `law`: u_i = `law.control(..)`, then
    /// ẍ_i = u_i integrated (semi-implicit Euler); in 2-D z stays 0. Returns u_i.
    pub fn step_with(&mut self, law: &dyn ControlLaw, inputs: &AgentInputs<'_>, dt: f64) -> Vec3 {
        let u = law.control(&self.position, &self.velocity, inputs);
        let (x, v) = integrate(&self.position, &self.velocity, &u, dt);
        self.position = x;
        self.velocity = v;
        if self.dim == 2 {
            self.position.z = 0.0;
            self.velocity.z = 0.0;
        }
        u
    }

    /// Holds station when nothing is heard from the coordinator (docs/ARCHITECTURE.md §7): damping and
    /// the last known virtual leaders only, no neighbours.
    pub fn hold_station(
        &mut self,
        last_leaders: &[Vec3],
        leader: &PairPotential,
        damping: f64,
        dt: f64,
    ) -> Vec3 {
        self.hold_station_with(&PaperLaw, last_leaders, leader, damping, dt)
    }

    /// [`Agent::hold_station`] under `law`.
    pub fn hold_station_with(
        &mut self,
        law: &dyn ControlLaw,
        last_leaders: &[Vec3],
        leader: &PairPotential,
        damping: f64,
        dt: f64,
    ) -> Vec3 {
        let inputs = Self::hold_inputs(last_leaders, leader, damping);
        self.step_with(law, &inputs, dt)
    }

    /// The inputs of holding station: the last known virtual leaders `last_leaders` with
    /// the potential `leader` and `damping` (1/s), no neighbours.
    pub fn hold_inputs<'a>(
        last_leaders: &'a [Vec3],
        leader: &PairPotential,
        damping: f64,
    ) -> AgentInputs<'a> {
        let no_neighbours = PairPotential {
            alpha: 0.0,
            d0: 1.0,
            d1: 0.0,
        };
        AgentInputs::paper(last_leaders, &[], no_neighbours, *leader, damping)
    }
}

/// The control law the shipped binaries fly for `mission`: [`RobustLaw`] (with the memory
/// `control.neighbour_memory`) under `control.law = "robust"`, [`PaperLaw`] otherwise.
pub fn mission_law(mission: &Mission) -> Arc<dyn ControlLaw> {
    match mission.control.law {
        LawKind::Paper => Arc::new(PaperLaw),
        LawKind::Robust => Arc::new(RobustLaw::new(mission.control.neighbour_memory)),
    }
}

/// The initial formation design of a mission (before any loss): regular polygon /
/// Platonic solid of the mission's radius around one central leader.
pub fn initial_design(
    mission: &Mission,
) -> Result<FormationDesign, vbap_math::formation::FormationError> {
    vbap_math::formation::design_regular(
        mission.vehicles.count,
        mission.formation_dim(),
        mission.formation.radius,
        mission.formation.alpha,
        mission.formation.alpha,
    )
}

/// The initial state of vehicle `id`: its slot of the initial design around
/// `vehicles.start`, displaced by at most `vehicles.start_spread` in a direction and by an
/// amount drawn from the key (seed, InitialPosition, id, 0); at rest.
pub fn initial_agent(mission: &Mission, design: &FormationDesign, id: u32) -> Agent {
    let dim = mission.mission.dim;
    let slot = design
        .slots
        .get(id as usize)
        .copied()
        .unwrap_or_else(Vec3::zeros);
    let mut rng = keyed(
        mission.mission.seed,
        Stream::InitialPosition,
        u64::from(id),
        0,
    );
    // Uniform in the unit disc / ball by rejection (a bounded number of draws in practice).
    let offset = loop {
        let mut o = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if dim == 2 {
            o.z = 0.0;
        }
        if o.norm_squared() <= 1.0 {
            break o;
        }
    };
    let mut position = mission.start_vec() + slot + offset * mission.vehicles.start_spread;
    if dim == 2 {
        position.z = 0.0;
    }
    Agent {
        id,
        dim,
        position,
        velocity: Vec3::zeros(),
    }
}

/// What the coordinator tells a vehicle for one step: the virtual leaders, the
/// neighbours' last known positions and the (scaled) potentials. The content of a body
/// command as one vehicle sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Guidance {
    /// Tick of the command.
    pub tick: u64,
    /// Virtual leader positions b_l(s), length unit.
    pub leaders: Vec<Vec3>,
    /// Positions of the other members (ordered by id).
    pub neighbours: Vec<Vec3>,
    /// Scaled inter-vehicle potential.
    pub inter: PairPotential,
    /// Scaled vehicle–leader potential.
    pub leader: PairPotential,
    /// Damping gain of (II.1), 1/s.
    pub damping: f64,
    /// Velocity of the virtual body, length unit/s: while no newer command is visible, the
    /// vehicle dead-reckons the leaders and its neighbours with it.
    pub velocity: Vec3,
    /// Homing weight σ_j of each neighbour (same order as `neighbours`; 0 unless it
    /// rejoins), `vbap_math::rejoin`.
    pub neighbour_sigmas: Vec<f64>,
    /// Slot of each neighbour that rejoins (same order; its own position otherwise).
    pub neighbour_slots: Vec<Vec3>,
    /// The slot this vehicle flies to while it rejoins, length unit (None: not rejoining).
    pub target: Option<Vec3>,
    /// Last known velocity of each neighbour (same order), length unit/s.
    pub neighbour_velocities: Vec<Vec3>,
    /// Age of the coordinator's information on each neighbour at the command's tick (same
    /// order), s; the vehicle adds the command's own age when it steps on an old command.
    pub neighbour_ages: Vec<f64>,
    /// This vehicle's own slot at the command's tick, length unit (None: the coordinator
    /// sent none; under `control.law = "robust"` it sends every member's).
    pub slot: Option<Vec3>,
    /// Approach speed of the homing law relative to the body, length unit/s: the body's
    /// nominal speed `body.v0`, which every vehicle flies anyway.
    pub rejoin_speed: f64,
    /// The body of the command and its committed path (robust law,
    /// `vbap_math::schedule`): out of contact the vehicle predicts the body from it
    /// instead of dead-reckoning at `velocity` (None: the paper's dead reckoning).
    pub plan: Option<BodyPlan>,
}

impl Guidance {
    /// This guidance for vehicle `id` of a body command: as neighbours every member or
    /// admitted vehicle of the command's snapshot but itself, each with its homing weight
    /// σ_j (from its position and slot, for the spacing `inter.d0`); its own slot when it
    /// rejoins.
    ///
    /// The per-neighbour vectors a law may receive empty ([`ControlInputs`]) stay empty when
    /// they would hold nothing else: `neighbour_sigmas` and `neighbour_slots` while no
    /// neighbour rejoins (every σ_j = 0, every slot its position), `neighbour_ages` while
    /// every age is exactly +0 s. Every law reads them with those defaults, so u_i is the
    /// same bit for bit (test `compact_guidance_flies_as_the_full_one`); the vehicle copies
    /// two vectors per command instead of five (each agent reads the whole snapshot every
    /// tick: this copy was its largest cost at N = 1024).
    pub fn with_neighbours(
        self,
        id: u32,
        snapshot: &[vbap_ipc::msg::coordinator_to_agent::SnapshotEntry],
    ) -> Self {
        self.with_neighbours_and_own(id, snapshot).0
    }

    /// [`Guidance::with_neighbours`], and the first entry of the snapshot with this
    /// vehicle's id whatever its state (how a rejoining vehicle learns it is admitted), from
    /// the same pass.
    pub fn with_neighbours_and_own(
        mut self,
        id: u32,
        snapshot: &[vbap_ipc::msg::coordinator_to_agent::SnapshotEntry],
    ) -> (
        Self,
        Option<vbap_ipc::msg::coordinator_to_agent::SnapshotEntry>,
    ) {
        use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
        use vbap_ipc::msg::to_vec3;
        let spacing = self.inter.d0;
        let n = snapshot.len();
        self.neighbours = Vec::with_capacity(n);
        self.neighbour_velocities = Vec::with_capacity(n);
        self.neighbour_sigmas = Vec::new();
        self.neighbour_slots = Vec::new();
        self.neighbour_ages = Vec::new();
        let mut own_any: Option<&SnapshotEntry> = None;
        let mut own_alive: Option<&SnapshotEntry> = None;
        // Whether `neighbour_sigmas`/`neighbour_slots` and `neighbour_ages` are kept.
        let mut homing_kept = false;
        let mut ages_kept = false;
        for e in snapshot {
            if e.id == id {
                own_any.get_or_insert(e);
                if e.alive != SnapshotEntry::LOST {
                    own_alive.get_or_insert(e);
                }
                continue;
            }
            if e.alive == SnapshotEntry::LOST {
                continue;
            }
            let position = to_vec3(&e.position);
            let before = self.neighbours.len();
            if e.rejoining != 0 && !homing_kept {
                homing_kept = true;
                // The first neighbour that rejoins: the ones before it had σ = 0 and their
                // own position as slot.
                self.neighbour_sigmas = Vec::with_capacity(n);
                self.neighbour_sigmas.resize(before, 0.0);
                self.neighbour_slots = Vec::with_capacity(n);
                self.neighbour_slots.extend_from_slice(&self.neighbours);
            }
            if homing_kept {
                let (sigma, slot) = if e.rejoining != 0 {
                    let target = to_vec3(&e.target);
                    (homing_weight((position - target).norm(), spacing), target)
                } else {
                    (0.0, position)
                };
                self.neighbour_sigmas.push(sigma);
                self.neighbour_slots.push(slot);
            }
            if e.age.to_bits() != 0 && !ages_kept {
                ages_kept = true;
                // The first age that is not +0: the ones before it were.
                self.neighbour_ages = Vec::with_capacity(n);
                self.neighbour_ages.resize(before, 0.0);
            }
            if ages_kept {
                self.neighbour_ages.push(e.age);
            }
            self.neighbours.push(position);
            self.neighbour_velocities.push(to_vec3(&e.velocity));
        }
        self.target = own_alive
            .filter(|e| e.rejoining != 0)
            .map(|e| to_vec3(&e.target));
        self.slot = own_alive
            .filter(|e| e.has_slot != 0)
            .map(|e| to_vec3(&e.slot));
        (self, own_any.copied())
    }

    /// The guidance of a body command for the step from tick `tick` (its leaders,
    /// potentials, damping and body velocity; neighbours from [`Guidance::with_neighbours`]),
    /// for a vehicle homing at `rejoin_speed` (length unit/s) when it rejoins.
    #[allow(clippy::too_many_arguments)]
    pub fn of_command(
        tick: u64,
        leaders: Vec<Vec3>,
        inter: PairPotential,
        leader: PairPotential,
        damping: f64,
        velocity: Vec3,
        rejoin_speed: f64,
    ) -> Self {
        Self {
            tick,
            leaders,
            neighbours: Vec::new(),
            inter,
            leader,
            damping,
            velocity,
            neighbour_sigmas: Vec::new(),
            neighbour_slots: Vec::new(),
            target: None,
            rejoin_speed,
            neighbour_velocities: Vec::new(),
            neighbour_ages: Vec::new(),
            slot: None,
            plan: None,
        }
    }

    /// This guidance with the committed path `schedule` of its command, whose body is
    /// centred on `r` at scale `scale` (None: no committed path).
    pub fn with_plan(mut self, schedule: Option<BodySchedule>, r: Vec3, scale: f64) -> Self {
        self.plan = schedule.map(|schedule| BodyPlan {
            tick: self.tick,
            r,
            scale,
            schedule,
        });
        self
    }

    /// The guidance a vehicle starts with before it hears anything: the leaders of the
    /// initial virtual body (the plan it was deployed with), no neighbours.
    pub fn initial(mission: &Mission, design: &FormationDesign) -> Self {
        let body = VirtualBody {
            s: 0.0,
            r: mission.start_vec(),
            rotation: nalgebra::Rotation3::identity(),
            scale: 1.0,
        };
        Self {
            tick: 0,
            leaders: body.leader_positions(design),
            neighbours: Vec::new(),
            inter: body.scaled_inter(design),
            leader: body.scaled_leader(design),
            damping: mission.vehicles.damping,
            velocity: Vec3::zeros(),
            neighbour_sigmas: Vec::new(),
            neighbour_slots: Vec::new(),
            target: None,
            rejoin_speed: mission.body.v0,
            neighbour_velocities: Vec::new(),
            neighbour_ages: Vec::new(),
            slot: None,
            plan: None,
        }
    }
}

/// Counters of a vehicle's downlink.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DownlinkCounts {
    /// Commands delivered by the link model.
    pub delivered: u64,
    /// Commands dropped by the link model.
    pub dropped: u64,
}

/// One vehicle with its side of the link: the per-tick logic of an agent, pure. The
/// command of every tick arrives (it is the lockstep clock); the link model decides when
/// its content becomes visible; the vehicle steers by the newest visible guidance.
///
/// The fates of commands are drawn in command order, from the key (seed, vehicle, tick)
/// alone, so a vehicle can know before a command arrives that it will not be visible
/// for a while (under water, or a long delay): [`Vehicle::ready_to_step`] says whether
/// every command the next step needs is in. This is the conservative lookahead that lets
/// a submerged glider run ahead of the coordinator and still move exactly as in the
/// in-process simulator.
#[derive(Clone, Debug)]
pub struct Vehicle {
    /// The vehicle's dynamics.
    pub agent: Agent,
    link: LinkState,
    inbox: DelayQueue<Guidance>,
    current: Guidance,
    /// The next command whose fate is to be drawn.
    next_fate: u64,
    /// Fates drawn for commands not received yet (command tick → fate).
    ahead: BTreeMap<u64, Fate>,
    /// Fates drawn since [`Vehicle::take_drawn`] was last called (for the logs).
    drawn: Vec<(u64, Fate)>,
    /// Downlink counters.
    pub counts: DownlinkCounts,
    /// The control law it flies ([`PaperLaw`] unless [`Vehicle::with_law`]).
    law: Arc<dyn ControlLaw>,
    /// Beyond the ideal vehicle (glider, current, land; [`Vehicle::with_motion`]): what it
    /// believes and feels. None: the paper's vehicle, `agent` is all.
    pub moving: Option<motion::Moving>,
}

/// What a vehicle reports of itself: its believed position and its velocity through the
/// water (the truth for the ideal vehicle), and the current at its true position (zero in
/// still water), all at the tick of its state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reported {
    /// Believed position, length unit.
    pub position: Vec3,
    /// Velocity through the water, length unit/s.
    pub water: Vec3,
    /// Current at the true position, length unit/s.
    pub current: Vec3,
}

impl Vehicle {
    /// A vehicle starting with `initial` guidance, whose first command is that of tick
    /// `first_command` (0 at the start of a mission, the tick of admission for a vehicle
    /// admitted back).
    pub fn new(agent: Agent, initial: Guidance, first_command: u64) -> Self {
        Self {
            agent,
            link: LinkState::default(),
            inbox: DelayQueue::default(),
            current: initial,
            next_fate: first_command,
            ahead: BTreeMap::new(),
            drawn: Vec::new(),
            counts: DownlinkCounts::default(),
            law: Arc::new(PaperLaw),
            moving: None,
        }
    }

    /// This vehicle moving by `kin` (None: the paper's ideal vehicle). Its state is that of
    /// its first command's tick (tick length `dt`, s).
    pub fn with_motion(mut self, kin: Option<Arc<motion::Kinematics>>, dt: f64) -> Self {
        self.moving =
            kin.map(|kin| motion::Moving::start(kin, &mut self.agent, self.next_fate, dt));
        self
    }

    /// What this vehicle reports of itself ([`Reported`]).
    pub fn reported(&self) -> Reported {
        match &self.moving {
            Some(m) => Reported {
                position: m.belief,
                water: m.water,
                current: m.current,
            },
            None => Reported {
                position: self.agent.position,
                water: self.agent.velocity,
                current: Vec3::zeros(),
            },
        }
    }

    /// This vehicle flying `law` instead of the paper's.
    pub fn with_law(mut self, law: Arc<dyn ControlLaw>) -> Self {
        self.law = law;
        self
    }

    /// The control law this vehicle flies.
    pub fn law(&self) -> &Arc<dyn ControlLaw> {
        &self.law
    }

    /// Nothing heard from the coordinator: hold station around the last visible leaders
    /// (damping and leader forces only, docs/ARCHITECTURE.md §7).
    /// `k` is the tick the step starts from.
    pub fn hold_station(&mut self, k: u64, dt: f64) {
        let g = self.current.clone();
        if self.moving.is_none() {
            self.agent
                .hold_station_with(self.law.as_ref(), &g.leaders, &g.leader, g.damping, dt);
            return;
        }
        let inputs = Agent::hold_inputs(&g.leaders, &g.leader, g.damping);
        fly(
            &mut self.agent,
            &mut self.moving,
            self.law.as_ref(),
            &inputs,
            k,
            dt,
        );
    }

    /// Draws the fates of the commands up to tick `c` that have none yet, in order.
    fn draw_fates(&mut self, model: &LinkModel, c: u64, dt: f64) {
        while self.next_fate <= c {
            let k = self.next_fate;
            let t = k as f64 * dt;
            let fate = model.fate(&mut self.link, self.agent.id, Direction::Downlink, k, t);
            match fate {
                Fate::Deliver { .. } => self.counts.delivered += 1,
                Fate::Drop(_) => self.counts.dropped += 1,
            }
            self.ahead.insert(k, fate);
            self.drawn.push((k, fate));
            self.next_fate += 1;
        }
    }

    /// The command of tick `c` arrives with `guidance`: held until the link delivers it.
    /// Returns its fate (None: a command from before this vehicle's first, or one already
    /// received).
    pub fn receive(
        &mut self,
        model: &LinkModel,
        guidance: Guidance,
        c: u64,
        dt: f64,
    ) -> Option<Fate> {
        self.draw_fates(model, c, dt);
        let fate = self.ahead.remove(&c)?;
        if let Fate::Deliver { at, .. } = fate {
            self.inbox.push(at, guidance);
        }
        Some(fate)
    }

    /// True when the step from tick `j` has every command it needs: no command of a tick
    /// up to `j` that has not arrived yet is delivered by t_j.
    pub fn ready_to_step(&mut self, model: &LinkModel, j: u64, dt: f64) -> bool {
        self.draw_fates(model, j, dt);
        let t = j as f64 * dt;
        !self
            .ahead
            .range(..=j)
            .any(|(_, f)| matches!(f, Fate::Deliver { at, .. } if *at <= t))
    }

    /// Stops waiting for the commands before tick `c` that never came (a paced run skips
    /// late commands; in lockstep every command comes).
    pub fn forget_before(&mut self, c: u64) {
        self.ahead = self.ahead.split_off(&c);
    }

    /// The fates drawn since the last call, as (command tick, fate).
    pub fn take_drawn(&mut self) -> Vec<(u64, Fate)> {
        std::mem::take(&mut self.drawn)
    }

    /// The command of tick `k` arrives, then the vehicle steps from tick k to k + 1 (the
    /// in-process simulator's tick). Returns the fate of the command ([`Vehicle::receive`]).
    pub fn on_command(
        &mut self,
        model: &LinkModel,
        guidance: Guidance,
        k: u64,
        dt: f64,
    ) -> Option<Fate> {
        let fate = self.receive(model, guidance, k, dt);
        self.step(k, dt);
        fate
    }

    /// Steps from tick `k` to k + 1 with the newest guidance visible at t_k (callers make
    /// sure every command it may need has arrived: [`Vehicle::ready_to_step`]).
    pub fn step(&mut self, k: u64, dt: f64) {
        let t = k as f64 * dt;
        if let Some(newest) = self.inbox.pop_due(t).into_iter().last() {
            self.current = newest;
        }
        let g = &self.current;
        let age = k.saturating_sub(g.tick) as f64 * dt;
        // Out of contact: dead-reckon the virtual body (leaders, neighbours, own slot) from
        // the last command: along its committed path when it carries one (robust law:
        // centre, scale and the scaled potentials of (III.3)), else at its velocity.
        let planned = g.plan.as_ref().filter(|_| age > 0.0).map(|p| p.at(k, dt));
        let shift = g.velocity * age;
        let moved = |p: &Vec3| match &planned {
            Some(body) => body.carry(p),
            None if age > 0.0 => p + shift,
            None => *p,
        };
        let (inter, leader, body_velocity) = match &planned {
            Some(b) => (
                g.inter.scaled(b.ratio),
                g.leader.scaled(b.ratio),
                b.velocity,
            ),
            None => (g.inter, g.leader, g.velocity),
        };
        let homing = g.target.map(|t| {
            Homing::towards(
                &self.reported().position,
                &moved(&t),
                inter.d0,
                &body_velocity,
                g.damping,
                g.rejoin_speed,
            )
        });
        if age > 0.0 {
            let leaders: Vec<Vec3> = g.leaders.iter().map(moved).collect();
            let neighbours: Vec<Vec3> = g.neighbours.iter().map(moved).collect();
            let slots: Vec<Vec3> = g.neighbour_slots.iter().map(moved).collect();
            // Empty ages are all +0 s ([`Guidance::with_neighbours`]): each is then `age`.
            let ages: Vec<f64> = if g.neighbour_ages.is_empty() {
                vec![age; g.neighbours.len()]
            } else {
                g.neighbour_ages.iter().map(|a| a + age).collect()
            };
            let inputs = AgentInputs {
                neighbour_sigmas: &g.neighbour_sigmas,
                neighbour_slots: &slots,
                homing,
                neighbour_velocities: &g.neighbour_velocities,
                neighbour_ages: &ages,
                slot: g.slot.as_ref().map(moved),
                body_velocity,
                ..AgentInputs::paper(&leaders, &neighbours, inter, leader, g.damping)
            };
            fly(
                &mut self.agent,
                &mut self.moving,
                self.law.as_ref(),
                &inputs,
                k,
                dt,
            );
        } else {
            let inputs = AgentInputs {
                neighbour_sigmas: &g.neighbour_sigmas,
                neighbour_slots: &g.neighbour_slots,
                homing,
                neighbour_velocities: &g.neighbour_velocities,
                neighbour_ages: &g.neighbour_ages,
                slot: g.slot,
                body_velocity: g.velocity,
                ..AgentInputs::paper(&g.leaders, &g.neighbours, g.inter, g.leader, g.damping)
            };
            fly(
                &mut self.agent,
                &mut self.moving,
                self.law.as_ref(),
                &inputs,
                k,
                dt,
            );
        }
    }
}

/// One step of `agent` from tick `k` under `law` with `inputs`: the paper's
/// ([`Agent::step_with`]) or, beyond it (`moving`), [`motion::Moving::step`].
fn fly(
    agent: &mut Agent,
    moving: &mut Option<motion::Moving>,
    law: &dyn ControlLaw,
    inputs: &AgentInputs<'_>,
    k: u64,
    dt: f64,
) {
    match moving {
        Some(m) => {
            m.step(agent, law, inputs, k, dt);
        }
        None => {
            agent.step_with(law, inputs, dt);
        }
    }
}
