//! One vehicle with its side of the link ([`Vehicle`]): the per-tick logic of an agent,
//! pure (the process around it is `run`).

use std::collections::BTreeMap;
use std::sync::Arc;

use vbap_math::law::{ControlLaw, PaperLaw};
use vbap_math::rejoin::Homing;
use vbap_math::robust::{derived_memory, fuse, Source};
use vbap_math::Vec3;
use vbap_mission::acoustic::{AcousticModel, Ear, Frame, Heard};
use vbap_mission::link::{DelayQueue, Direction, DropReason, Fate, LinkModel, LinkState};

use crate::{motion, Agent, AgentInputs, Guidance};

/// Counters of a vehicle's downlink.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DownlinkCounts {
    /// Commands delivered by the link model.
    pub delivered: u64,
    /// Commands dropped by the link model.
    pub dropped: u64,
    /// Commands the shore replaced with a newer one (Iridium).
    pub superseded: u64,
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
    /// The tick of its first state (deployment or restart).
    first: u64,
    /// Its acoustic modem's receiver (`[acoustic]`, [`Vehicle::with_acoustic`]), and the
    /// neighbour memory τ (s; None: derived from the potentials) its sources are fused with.
    acoustic: Option<(Ear, Option<f64>)>,
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
            first: first_command,
            acoustic: None,
        }
    }

    /// This vehicle with an acoustic modem on `channel` (None: without), fusing what it
    /// hears with the coordinator's relay under neighbour memory `memory` s
    /// (`control.neighbour_memory`; None: `vbap_math::robust::derived_memory`).
    /// `verdicts`: keep each frame's verdict for the message records.
    pub fn with_acoustic(
        mut self,
        channel: Option<Arc<AcousticModel>>,
        memory: Option<f64>,
        verdicts: bool,
    ) -> Self {
        self.acoustic = channel.map(|m| {
            let ear = Ear::new(m, self.agent.id, self.first);
            (
                if verdicts {
                    ear.keeping_verdicts()
                } else {
                    ear
                },
                memory,
            )
        });
        self
    }

    /// Its acoustic receiver (None without `[acoustic]`).
    pub fn ear(&self) -> Option<&Ear> {
        self.acoustic.as_ref().map(|(e, _)| e)
    }

    /// Its acoustic receiver, to hand it frames (None without `[acoustic]`).
    pub fn ear_mut(&mut self) -> Option<&mut Ear> {
        self.acoustic.as_mut().map(|(e, _)| e)
    }

    /// The frames its modem sends during tick `k`, its state being that of tick `k` (none
    /// without `[acoustic]`); its own receiver is deaf meanwhile.
    pub fn transmit(&mut self, k: u64) -> Vec<Frame> {
        let said = self.reported();
        let (id, first, truth) = (self.agent.id, self.first, self.agent.position);
        let Some((ear, _)) = &mut self.acoustic else {
            return Vec::new();
        };
        let frames = ear
            .model()
            .frames(id, k, first, truth, said.position, said.water);
        for f in &frames {
            ear.transmitted(f);
        }
        frames
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
                Fate::Drop(DropReason::Superseded) => self.counts.superseded += 1,
                Fate::Drop(_) => self.counts.dropped += 1,
            }
            self.ahead.insert(k, fate);
            self.drawn.push((k, fate));
            self.next_fate += 1;
        }
    }

    /// The command of tick `c` arrives with `guidance`, `bytes` bytes as its link carries
    /// it: held until the link delivers it. Its fate by the schedule was drawn before
    /// ([`LinkModel::fate`]); its size now adds its transfer time, or refuses it
    /// ([`LinkModel::carry`]: Iridium; a refusal is counted and logged as a drop). Returns
    /// its fate (None: a command from before this vehicle's first, or one already
    /// received).
    pub fn receive(
        &mut self,
        model: &LinkModel,
        guidance: Guidance,
        bytes: u64,
        c: u64,
        dt: f64,
    ) -> Option<Fate> {
        self.draw_fates(model, c, dt);
        let drawn = self.ahead.remove(&c)?;
        let fate = model.carry(
            drawn,
            self.agent.id,
            Direction::Downlink,
            c,
            c as f64 * dt,
            bytes,
        );
        match fate {
            Fate::Deliver { at, .. } => self.inbox.push(at, guidance),
            Fate::Drop(_) if matches!(drawn, Fate::Deliver { .. }) => {
                self.counts.delivered -= 1;
                self.counts.dropped += 1;
                self.drawn.push((c, fate));
            }
            Fate::Drop(_) => {}
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
        bytes: u64,
        k: u64,
        dt: f64,
    ) -> Option<Fate> {
        let fate = self.receive(model, guidance, bytes, k, dt);
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
        let truth = self.agent.position;
        let heard: Vec<Heard> = match &mut self.acoustic {
            Some((ear, _)) => {
                ear.track(k, truth);
                ear.decide(k);
                ear.heard().copied().collect()
            }
            None => Vec::new(),
        };
        let memory = self.acoustic.as_ref().and_then(|(_, m)| *m);
        let g = &self.current;
        let age = k.saturating_sub(g.tick) as f64 * dt;
        // Out of contact: dead-reckon the virtual body (leaders, neighbours, own slot) from
        // the last command: along its committed path when it carries one (robust law:
        // centre, scale and the scaled potentials of (III.3)), else at its velocity.
        let now = g.plan.as_ref().map(|p| (p, p.at(k, dt)));
        let planned = now.filter(|_| age > 0.0).map(|(_, b)| b);
        // The body's growth k̇/k now and its centre, from the committed path (the slots'
        // velocity, `AgentInputs::slot_velocity`); unknown without one.
        let (body_growth, body_centre) = match now {
            Some((p, now)) => {
                let rate = p.schedule.segment_at(k.max(p.tick)).scale_rate;
                let growth = if now.scale > 0.0 {
                    rate / now.scale
                } else {
                    0.0
                };
                (growth, now.r)
            }
            None => (0.0, Vec3::zeros()),
        };
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
            let others: Vec<Vec3> = g.neighbours.iter().map(moved).collect();
            Homing::around(
                &self.reported().position,
                &moved(&t),
                &others,
                inter.d0,
                &body_velocity,
                g.damping,
                g.rejoin_speed,
            )
        });
        let hearing = Hearing {
            ids: &g.neighbour_ids,
            heard: &heard,
            now: t,
            dt,
            memory,
        };
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
                body_growth,
                body_centre,
                hulls: &g.hulls,
                ..AgentInputs::paper(&leaders, &neighbours, inter, leader, g.damping)
            };
            hearing.fly(
                &mut self.agent,
                &mut self.moving,
                self.law.as_ref(),
                &inputs,
                k,
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
                body_growth,
                body_centre,
                hulls: &g.hulls,
                ..AgentInputs::paper(&g.leaders, &g.neighbours, g.inter, g.leader, g.damping)
            };
            hearing.fly(
                &mut self.agent,
                &mut self.moving,
                self.law.as_ref(),
                &inputs,
                k,
            );
        }
    }
}

/// What a vehicle's acoustic modem has decoded, for one step at mission time `now` (s):
/// fused into the neighbour terms of the coordinator's relay ([`Hearing::fly`]).
struct Hearing<'a> {
    /// The relay's neighbours' ids (same order as the inputs' neighbours).
    ids: &'a [u32],
    /// The newest frame decoded from each sender.
    heard: &'a [Heard],
    now: f64,
    dt: f64,
    /// τ of the fusion, s (None: derived from the potentials).
    memory: Option<f64>,
}

impl Hearing<'_> {
    /// [`fly`] with `inputs`' neighbours fused with what was heard: a neighbour of both
    /// sources gets each weighed by its own age (`vbap_math::robust::fuse`); a vehicle only
    /// heard, less than the memory τ ago, is added, its position carried with the body (its
    /// velocity and growth) for its age. Nothing heard, or no leaders yet (a restarted vehicle before its first
    /// command):
    /// `inputs` as they are (bit for bit the flight without a modem).
    fn fly(
        &self,
        agent: &mut Agent,
        moving: &mut Option<motion::Moving>,
        law: &dyn ControlLaw,
        inputs: &AgentInputs<'_>,
        k: u64,
    ) {
        match self.fused(inputs) {
            Some(n) => {
                let fused = AgentInputs {
                    neighbours: &n.positions,
                    neighbour_velocities: &n.velocities,
                    neighbour_ages: &n.ages,
                    neighbour_sigmas: &n.sigmas,
                    neighbour_slots: &n.slots,
                    ..*inputs
                };
                fly(agent, moving, law, &fused, k, self.dt)
            }
            None => fly(agent, moving, law, inputs, k, self.dt),
        }
    }

    /// The neighbours of `inputs` fused with what was heard ([`Hearing::fly`]); None when
    /// they stay as they are.
    fn fused(&self, inputs: &AgentInputs<'_>) -> Option<Neighbours> {
        // A vehicle restarted and not yet told anything (no leaders) only brakes
        // (`Guidance::restarted`): neighbours heard without leaders to balance them threw
        // a rejoining vehicle at 8.7 V_U in a random mission (stress seed 11, m0657).
        if self.heard.is_empty() || inputs.leaders.is_empty() {
            return None;
        }
        let memory = self
            .memory
            .unwrap_or_else(|| derived_memory(&inputs.inter, inputs.damping));
        let n = inputs.neighbours.len();
        let mut positions = inputs.neighbours.to_vec();
        let mut velocities: Vec<Vec3> = (0..n)
            .map(|j| {
                inputs
                    .neighbour_velocities
                    .get(j)
                    .copied()
                    .unwrap_or_else(Vec3::zeros)
            })
            .collect();
        let mut ages: Vec<f64> = (0..n)
            .map(|j| inputs.neighbour_ages.get(j).copied().unwrap_or(0.0))
            .collect();
        let homing = !inputs.neighbour_sigmas.is_empty();
        let mut sigmas = inputs.neighbour_sigmas.to_vec();
        let mut slots = inputs.neighbour_slots.to_vec();
        for h in self.heard {
            let age = (self.now - h.tick as f64 * self.dt).max(0.0);
            // Carried with the body as a point of it: its centre's velocity and, on a
            // growing or shrinking formation, k̇/k of its offset from the centre (as the
            // relay's positions are carried along the committed path).
            let carried =
                inputs.body_velocity + inputs.body_growth * (h.position - inputs.body_centre);
            let heard = Source {
                position: h.position + carried * age,
                velocity: h.velocity,
                age,
            };
            match self.ids.iter().position(|&id| id == h.sender) {
                Some(j) if j < n => {
                    let relay = Source {
                        position: positions[j],
                        velocity: velocities[j],
                        age: ages[j],
                    };
                    let f = fuse(&relay, &heard, memory);
                    (positions[j], velocities[j], ages[j]) = (f.position, f.velocity, f.age);
                }
                // Heard only: added while fresher than the memory (older, the robust law
                // would keep less than 1/e of it, and its prediction along the body
                // drifts; a vehicle lost to the coordinator is heard from no more).
                _ if age > memory => {}
                _ => {
                    positions.push(heard.position);
                    velocities.push(heard.velocity);
                    ages.push(age);
                    if homing {
                        sigmas.push(0.0);
                        slots.push(heard.position);
                    }
                }
            }
        }
        Some(Neighbours {
            positions,
            velocities,
            ages,
            sigmas,
            slots,
        })
    }
}

/// A vehicle's neighbour terms, owned ([`Hearing::fused`]): the per-neighbour slices of
/// [`AgentInputs`].
#[derive(Debug, PartialEq)]
struct Neighbours {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    ages: Vec<f64>,
    sigmas: Vec<f64>,
    slots: Vec<Vec3>,
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

#[cfg(test)]
mod hearing_tests {
    use super::*;
    use vbap_math::potential::PairPotential;

    fn heard(sender: u32, tick: u64, x: f64) -> Heard {
        Heard {
            sender,
            tick,
            position: Vec3::new(x, 0.0, 0.0),
            velocity: Vec3::zeros(),
        }
    }

    /// The relay knows neighbour 1 at x = 0, 100 s old; the modem heard it at x = 10, 5 s
    /// ago, and vehicle 2 (not relayed) at x = 20, 5 s ago, and vehicle 3 long ago.
    #[test]
    fn heard_neighbours_are_fused_by_age_and_added_while_fresh() {
        let pot = PairPotential {
            alpha: 1.0,
            d0: 1.0,
            d1: 2.0,
        };
        let leaders = [Vec3::zeros()];
        let relay = [Vec3::zeros()];
        let inputs = AgentInputs {
            neighbour_ages: &[100.0],
            ..AgentInputs::paper(&leaders, &relay, pot, pot, 1.0)
        };
        let frames = [heard(1, 95, 10.0), heard(2, 95, 20.0), heard(3, 0, 30.0)];
        let hearing = Hearing {
            ids: &[1],
            heard: &frames,
            now: 100.0,
            dt: 1.0,
            memory: Some(10.0),
        };
        let n = hearing.fused(&inputs).expect("something was heard");
        // Weights e^{-10} (relay) and e^{-0.5} (heard): nearly the heard position, 5 s old.
        let (wr, wh) = ((-10.0f64).exp(), (-0.5f64).exp());
        assert!((n.positions[0].x - 10.0 * wh / (wr + wh)).abs() < 1e-12);
        assert_eq!(n.ages, vec![5.0, 5.0]);
        // Vehicle 2 added; vehicle 3, heard 100 s ago (> τ), not.
        assert_eq!(n.positions.len(), 2);
        assert_eq!(n.positions[1].x, 20.0);
        // Nothing heard, or no leaders (a restarted vehicle): the inputs as they are.
        let deaf = Hearing {
            heard: &[],
            ..hearing
        };
        assert!(deaf.fused(&inputs).is_none());
        let restarted = AgentInputs {
            leaders: &[],
            ..inputs
        };
        assert!(hearing.fused(&restarted).is_none());
    }
}
