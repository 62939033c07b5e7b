//! Zero-copy payloads, grouped by direction (`agent_to_coordinator`, ...).
//!
//! Every payload is `#[repr(C)]`, `Copy`, fixed size and `ZeroCopySend`, with an explicit,
//! versioned type name: change the version whenever the layout changes, so an old process
//! can never read a new layout. Every payload starts with a [`Header`] (docs/ARCHITECTURE.md §5).

use iceoryx2_bb_derive_macros::ZeroCopySend;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;

use vbap_math::potential::PairPotential;
use vbap_math::schedule::{BodySchedule, Segment, MAX_PLAN};
use vbap_math::Vec3;

/// Largest fleet a mission may have (fixed capacity of the swarm snapshot).
pub const MAX_VEHICLES: usize = 1024;
/// Largest fleet on one acoustic channel (`[acoustic]`): every agent publishes to, reads
/// from and wakes every other, so the ports grow as N².
pub const MAX_ACOUSTIC_VEHICLES: usize = 64;
/// Largest number of virtual leaders a formation design may have.
pub const MAX_LEADERS: usize = 256;
/// Capacity of a body command's neighbour lists: [`vbap_math::neighbourhood::MAX_NEAR`]
/// for each of [`MAX_VEHICLES`] snapshot entries.
pub const MAX_NEAR_ENTRIES: usize = MAX_VEHICLES * vbap_math::neighbourhood::MAX_NEAR;

/// Wall-clock time now, in nanoseconds since the Unix epoch (for latency analysis only;
/// the control law never sees it).
pub fn wall_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// What every payload carries first.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("vbap.Header.v1")]
pub struct Header {
    /// Sender id: the vehicle id, or [`Header::COORDINATOR`] / [`Header::FIELD_SERVER`].
    pub sender: u32,
    /// Bit flags, meaning defined by the payload.
    pub flags: u32,
    /// Control tick k.
    pub tick: u64,
    /// Mission time t = k·dt, s.
    pub t: f64,
    /// Per-sender sequence number, strictly increasing (replays are rejected).
    pub seq: u64,
    /// Send wall-clock time, ns since the Unix epoch.
    pub sent_ns: u64,
}

impl Header {
    /// Sender id of the coordinator.
    pub const COORDINATOR: u32 = u32::MAX - 1;
    /// Sender id of the field server.
    pub const FIELD_SERVER: u32 = u32::MAX - 2;
    /// Sender id of the supervisor (`vbap run`).
    pub const SUPERVISOR: u32 = u32::MAX - 3;

    /// The header of message `seq` of `sender` for tick `tick` at mission time `t` (s), no
    /// flags, stamped with the wall clock now ([`wall_ns`]): call it just before sending.
    pub fn new(sender: u32, tick: u64, t: f64, seq: u64) -> Self {
        Self {
            sender,
            flags: 0,
            tick,
            t,
            seq,
            sent_ns: wall_ns(),
        }
    }

    /// A header naming only its sender (no tick, sequence or stamp): messages outside the
    /// tick's clock, such as the supervisor's process exits.
    pub fn from_sender(sender: u32) -> Self {
        Self {
            sender,
            ..Self::default()
        }
    }

    /// This header with flags `flags`.
    pub fn with_flags(self, flags: u32) -> Self {
        Self { flags, ..self }
    }

    /// This header sent again as message `seq`, stamped with the wall clock now (tick,
    /// time, sender and flags kept).
    pub fn resent(self, seq: u64) -> Self {
        Self {
            seq,
            sent_ns: wall_ns(),
            ..self
        }
    }
}

/// Converts a payload array to a vector.
pub fn to_vec3(a: &[f64; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Converts a vector to a payload array.
pub fn from_vec3(v: &Vec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Converts a payload triple (alpha, d0, d1) to a pair potential of (III.3).
pub fn to_potential(p: &[f64; 3]) -> PairPotential {
    PairPotential {
        alpha: p[0],
        d0: p[1],
        d1: p[2],
    }
}

/// Converts a pair potential of (III.3) to its payload triple (alpha, d0, d1).
pub fn from_potential(p: &PairPotential) -> [f64; 3] {
    [p.alpha, p.d0, p.d1]
}

/// Vehicle → coordinator.
pub mod agent_to_coordinator {
    use super::*;

    versioned! {
    "vbap.VehicleState.v5", RawVehicleState;
    /// A vehicle's state at tick `header.tick` (service `<mission>/vehicle/<id>/state`).
    /// Its sensor reading is taken where and when this state says, by the field server,
    /// batched for the whole tick (see [`super::coordinator_to_field`]).
    #[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
    #[repr(C)]
    pub struct VehicleState {
        pub header: Header,
        /// OS process id of the agent (the coordinator SIGKILLs it for a scheduled kill).
        pub pid: u32,
        /// Incarnation of the vehicle's process: 1 for the first process the supervisor
        /// started in the vehicle's slot, one more for each restart (0: unknown, an agent
        /// started by hand). A state of a later incarnation than the coordinator knows is a
        /// new process (a loss then a rejoin), one of an earlier incarnation the last words
        /// of a dead one. Was padding (always 0) before; same layout.
        pub incarnation: u32,
        /// Position x_i, length unit.
        pub position: [f64; 3],
        /// Velocity ẋ_i, length unit/s.
        pub velocity: [f64; 3],
        /// Commands read so far: one more than the tick of the newest command the agent has
        /// taken from its buffer (0: none). The coordinator publishes no command that
        /// could overflow an agent's command buffer (lockstep flow control).
        pub commands_read: u64,
        /// What the vehicle believes its position is (dead reckoning since its last GPS
        /// fix; = `position` for the paper's ideal vehicle), length unit. The planner sees
        /// this; `position` is the truth (sensing, run files). Since v5.
        pub believed: [f64; 3],
        /// Velocity through the water (= `velocity` in still water), length unit/s; the
        /// velocity the vehicle reports. Since v5.
        pub water_velocity: [f64; 3],
        /// The current at `position`, length unit/s (zero in still water). Since v5.
        pub current: [f64; 3],
    }
    }

    impl VehicleState {
        /// Flag: the agent is holding station (heard nothing from the coordinator).
        pub const HOLDING: u32 = 1;
        /// Flag: a (re)started agent asks to join a mission under way; the state is its
        /// last known one, not a report of the tick.
        pub const JOINING: u32 = 2;
        /// Flag: no new state, only a newer `commands_read` (an agent that ran ahead and
        /// waits reports that it keeps reading commands).
        pub const ACK: u32 = 4;

        /// True when every number is finite.
        pub fn is_finite(&self) -> bool {
            self.header.t.is_finite()
                && self.position.iter().all(|v| v.is_finite())
                && self.velocity.iter().all(|v| v.is_finite())
                && self
                    .believed
                    .iter()
                    .chain(&self.water_velocity)
                    .chain(&self.current)
                    .all(|v| v.is_finite())
        }
    }
}

/// Coordinator → vehicles.
pub mod coordinator_to_agent {
    use super::*;

    /// One vehicle's last known state, as the coordinator holds it.
    #[derive(
        Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, serde::Serialize, serde::Deserialize,
    )]
    #[repr(C)]
    #[type_name("vbap.SnapshotEntry.v4")]
    pub struct SnapshotEntry {
        /// Vehicle id.
        pub id: u32,
        /// [`SnapshotEntry::LOST`], [`SnapshotEntry::MEMBER`] or [`SnapshotEntry::ADMITTED`].
        pub alive: u32,
        /// 1 while the vehicle rejoins (flies to `target`, `vbap_math::rejoin`), else 0.
        pub rejoining: u32,
        /// The incarnation of the vehicle's process this entry is about
        /// ([`super::agent_to_coordinator::VehicleState::incarnation`]; 0: unknown): an
        /// agent takes [`SnapshotEntry::ADMITTED`] as its own admission only when it names
        /// its own incarnation (or 0). Was padding (always 0) before; same layout.
        pub incarnation: u32,
        /// Position, length unit.
        pub position: [f64; 3],
        /// Velocity, length unit/s.
        pub velocity: [f64; 3],
        /// The slot a rejoining vehicle flies to, at this tick, length unit (zeros when not
        /// rejoining).
        pub target: [f64; 3],
        /// This vehicle's own slot of the design at this tick (its virtual leader under
        /// `control.law = "robust"`, `vbap_math::robust`), length unit; meaningful only when
        /// `has_slot` is 1 (zeros otherwise).
        #[serde(default)]
        pub slot: [f64; 3],
        /// Age of the coordinator's information on this vehicle, s: the command's time
        /// minus the time of the state `position` and `velocity` were taken from (0 for a
        /// state of this very tick; `position` is already moved with the body since then).
        #[serde(default)]
        pub age: f64,
        /// 1 when `slot` holds this vehicle's slot, else 0.
        #[serde(default)]
        pub has_slot: u32,
        #[serde(default)]
        pub _pad2: u32,
    }

    /// The index in `entries` (ordered by id) of vehicle `id`'s entry: its first that is
    /// not [`SnapshotEntry::LOST`], else its first. O(log N).
    pub fn own_index(entries: &[SnapshotEntry], id: u32) -> Option<usize> {
        let from = entries.partition_point(|e| e.id < id);
        let to = from + entries[from..].partition_point(|e| e.id == id);
        (from..to)
            .find(|&i| entries[i].alive != SnapshotEntry::LOST)
            .or((from < to).then_some(from))
    }

    impl SnapshotEntry {
        /// A lost vehicle: where its hull is, as the coordinator knows it (the last state
        /// received from it, dead-reckoned with the body to the loss; it does not move
        /// after). Vehicles under the robust law keep clear of it (`vbap_math::hull`); a
        /// restarted agent resumes from its ADMITTED entry instead.
        pub const LOST: u32 = 0;
        /// A member of the formation: its last state the coordinator received.
        pub const MEMBER: u32 = 1;
        /// Admitted back at this tick: the agent restores this state and steps from it.
        pub const ADMITTED: u32 = 2;

        /// How far this entry's vehicle may move relative to the body (velocity
        /// `body_velocity`, length/s) before it hears again, length: its speed relative to
        /// the body over the entry's age and the command horizon `horizon` (s;
        /// `vbap_math::neighbourhood::drift_margin`). A lost vehicle's hull does not move.
        /// The reach of the neighbour lists (coordinator) and of the leaders (agents).
        pub fn drift_margin(&self, body_velocity: &Vec3, horizon: f64) -> f64 {
            if self.alive == Self::LOST {
                return 0.0;
            }
            let relative = (to_vec3(&self.velocity) - body_velocity).norm();
            vbap_math::neighbourhood::drift_margin(relative, self.age, horizon)
        }
    }

    versioned! {
    "vbap.BodyCommand.v7", RawBodyCommand;
    /// The virtual body for the step from tick `header.tick` to the next, with the swarm
    /// snapshot and, for each entry, the entries within its reach (service
    /// `<mission>/body`). Agents read it in place (zero copy): each its own entry and the
    /// entries of its list, never the whole snapshot (v7: the lists).
    #[derive(Debug, Clone, Copy, ZeroCopySend)]
    #[repr(C)]
    pub struct BodyCommand {
        pub header: Header,
        /// Virtual body parameter s.
        pub s: f64,
        /// Formation speed ṡ (IV.4), 1/s.
        pub sdot: f64,
        /// Virtual body centre r, length unit.
        pub r: [f64; 3],
        /// Formation scale k (III.3).
        pub scale: f64,
        /// Scaled inter-vehicle potential (alpha, d0, d1) of (III.3).
        pub inter: [f64; 3],
        /// Scaled vehicle–leader potential (alpha, h0, h1) of (III.3).
        pub leader: [f64; 3],
        /// Damping gain K = damping·I of (II.1), 1/s.
        pub damping: f64,
        /// Velocity of the body centre dr/ds·ṡ, length unit/s (dead reckoning when out of
        /// contact).
        pub velocity: [f64; 3],
        /// Number of valid entries in `leaders`.
        pub n_leaders: u32,
        /// Number of valid entries in `snapshot` (ordered by id).
        pub n_vehicles: u32,
        /// Virtual leader positions b_l(s), length unit.
        pub leaders: [[f64; 3]; MAX_LEADERS],
        /// Every vehicle's last known state at this tick, ordered by id.
        pub snapshot: [SnapshotEntry; MAX_VEHICLES],
        /// Committed body path (robust law, `vbap_math::schedule`): first tick of
        /// `plan[0]`, relative to the body (`r`, `scale`) of this command.
        pub plan_start: u64,
        /// Ticks per segment of the committed path.
        pub plan_ticks: u64,
        /// Number of valid entries in `plan` (0: no committed path, dead-reckon at
        /// `velocity`).
        pub n_plan: u32,
        pub _plan_pad: u32,
        /// Segments of the committed path: velocity dr/dt (length unit/s, 3 numbers),
        /// scale rate dk/dt (1/s), ṡ (1/s).
        pub plan: [[f64; 5]; MAX_PLAN],
        /// Number of valid entries in `near` (= `near_start[n_vehicles]`). Since v7.
        pub n_near: u32,
        /// Snapshot entry `i`'s neighbour list is `near[near_start[i]..near_start[i + 1]]`
        /// (`i < n_vehicles`). Since v7.
        pub near_start: [u32; MAX_VEHICLES + 1],
        /// The neighbour lists: snapshot indices, ascending within a list
        /// (`vbap_coordinator::near`). Since v7.
        pub near: [u16; MAX_NEAR_ENTRIES],
    }
    }

    impl BodyCommand {
        /// Flag: the mission is over; agents exit.
        pub const FINISHED: u32 = 1;
        /// Flag: the body holds position (too few vehicles to estimate a gradient).
        pub const HOLDING: u32 = 2;

        /// An empty command (no leaders, no vehicles).
        pub fn empty() -> Self {
            Self {
                header: Header::default(),
                s: 0.0,
                sdot: 0.0,
                r: [0.0; 3],
                scale: 1.0,
                inter: [0.0; 3],
                leader: [0.0; 3],
                damping: 0.0,
                velocity: [0.0; 3],
                n_leaders: 0,
                n_vehicles: 0,
                leaders: [[0.0; 3]; MAX_LEADERS],
                snapshot: [SnapshotEntry::default(); MAX_VEHICLES],
                plan_start: 0,
                plan_ticks: 0,
                n_plan: 0,
                _plan_pad: 0,
                plan: [[0.0; 5]; MAX_PLAN],
                n_near: 0,
                near_start: [0; MAX_VEHICLES + 1],
                near: [0; MAX_NEAR_ENTRIES],
            }
        }

        /// Snapshot entry `i`'s neighbour list (snapshot indices; empty when `i` is out of
        /// range or the lists are not valid, see [`BodyCommand::is_valid`]).
        pub fn near_of(&self, i: usize) -> &[u16] {
            let n_v = (self.n_vehicles as usize).min(MAX_VEHICLES);
            if i >= n_v {
                return &[];
            }
            let (a, b) = (self.near_start[i] as usize, self.near_start[i + 1] as usize);
            if a <= b && b <= (self.n_near as usize).min(MAX_NEAR_ENTRIES) {
                &self.near[a..b]
            } else {
                &[]
            }
        }

        /// The index in the snapshot of vehicle `id`'s entry (its first entry that is not
        /// [`SnapshotEntry::LOST`], else its first): O(log N), the snapshot being ordered
        /// by id.
        pub fn own_index(&self, id: u32) -> Option<usize> {
            own_index(self.snapshot_entries(), id)
        }

        /// The committed body path, if the command carries one.
        pub fn schedule(&self) -> Option<BodySchedule> {
            let n = (self.n_plan as usize).min(MAX_PLAN);
            (n > 0 && self.plan_ticks > 0).then(|| BodySchedule {
                start: self.plan_start,
                seg_ticks: self.plan_ticks,
                segments: self.plan[..n].iter().map(Segment::from_array).collect(),
            })
        }

        /// The virtual leader positions b_l(s) in use, length unit.
        pub fn leader_positions(&self) -> Vec<Vec3> {
            let n_l = (self.n_leaders as usize).min(MAX_LEADERS);
            self.leaders[..n_l].iter().map(to_vec3).collect()
        }

        /// The scaled inter-vehicle and vehicle–leader potentials of (III.3).
        pub fn potentials(&self) -> (PairPotential, PairPotential) {
            (to_potential(&self.inter), to_potential(&self.leader))
        }

        /// The swarm snapshot entries in use, ordered by id.
        pub fn snapshot_entries(&self) -> &[SnapshotEntry] {
            &self.snapshot[..(self.n_vehicles as usize).min(MAX_VEHICLES)]
        }

        /// True when every number in use is finite and the counts are in range.
        pub fn is_valid(&self) -> bool {
            let n_l = self.n_leaders as usize;
            let n_v = self.n_vehicles as usize;
            n_l <= MAX_LEADERS
                && n_v <= MAX_VEHICLES
                && [self.header.t, self.s, self.sdot, self.scale, self.damping]
                    .iter()
                    .chain(self.velocity.iter())
                    .chain(self.r.iter())
                    .chain(self.inter.iter())
                    .chain(self.leader.iter())
                    .all(|v| v.is_finite())
                && self.leaders[..n_l].iter().flatten().all(|v| v.is_finite())
                && (self.n_plan as usize) <= MAX_PLAN
                && (self.n_plan == 0 || self.plan_ticks > 0)
                && self.plan[..(self.n_plan as usize).min(MAX_PLAN)]
                    .iter()
                    .flatten()
                    .all(|v| v.is_finite())
                && self.near_is_valid()
                && self.snapshot[..n_v].iter().all(|e| {
                    e.position
                        .iter()
                        .chain(e.velocity.iter())
                        .chain(e.target.iter())
                        .chain(e.slot.iter())
                        .all(|v| v.is_finite())
                        && e.age.is_finite()
                })
        }

        /// True when the neighbour lists are in range: `n_near` within capacity and equal
        /// to the end of the last list, every list's start within the one after it, every
        /// index a snapshot entry.
        fn near_is_valid(&self) -> bool {
            let n_v = self.n_vehicles as usize;
            let n_near = self.n_near as usize;
            n_v <= MAX_VEHICLES
                && n_near <= MAX_NEAR_ENTRIES
                && self.near_start[0] == 0
                && self.near_start[n_v] as usize == n_near
                && self.near_start[..=n_v].windows(2).all(|w| w[0] <= w[1])
                && self.near[..n_near].iter().all(|&j| (j as usize) < n_v)
        }
    }
}

/// Coordinator → field server: the sensor reads of one tick, in one request.
///
/// Every vehicle's sensor reads where and when its state says. The coordinator, which
/// gathers the states of a tick anyway, asks the field server for all of them at once: one
/// round trip per tick instead of one per vehicle, and each agent wakes once per tick
/// (for its command) instead of twice. The readings are the same numbers the vehicles
/// would have read themselves: noise keyed by (seed, vehicle, tick), sensor faults applied
/// by the field server, which simulates the sensors.
pub mod coordinator_to_field {
    use super::*;

    /// Where and when one vehicle's sensor reads.
    #[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
    #[repr(C)]
    #[type_name("vbap.SensorRead.v1")]
    pub struct SensorRead {
        /// Vehicle id (keys the sensor noise).
        pub vehicle: u32,
        pub _pad: u32,
        /// Tick of the reading (keys the sensor noise).
        pub tick: u64,
        /// Mission time of the reading, s.
        pub t: f64,
        /// Sensor position, length unit.
        pub position: [f64; 3],
    }

    /// The sensor reads of one tick (service `<mission>/field/sample`).
    #[derive(Debug, Clone, Copy, ZeroCopySend)]
    #[repr(C)]
    #[type_name("vbap.SampleBatch.v2")]
    pub struct SampleBatch {
        pub header: Header,
        /// Number of valid entries in `reads`.
        pub n: u32,
        pub _pad: u32,
        pub reads: [SensorRead; MAX_VEHICLES],
    }

    impl SampleBatch {
        /// An empty batch.
        pub fn empty() -> Self {
            Self {
                header: Header::default(),
                n: 0,
                _pad: 0,
                reads: [SensorRead::default(); MAX_VEHICLES],
            }
        }
        /// The valid entries.
        pub fn reads(&self) -> &[SensorRead] {
            &self.reads[..(self.n as usize).min(MAX_VEHICLES)]
        }
    }
}

/// Field server → coordinator.
pub mod field_to_coordinator {
    use super::*;

    /// One vehicle's noisy reading T(p, t) + N(0, σ_M²), sensor faults applied.
    #[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
    #[repr(C)]
    #[type_name("vbap.Reading.v1")]
    pub struct Reading {
        /// Vehicle id.
        pub vehicle: u32,
        /// 1 when the read was rejected (non-finite position, unknown vehicle).
        pub rejected: u32,
        /// Tick of the reading.
        pub tick: u64,
        /// The reading, field unit (NaN when rejected).
        pub value: f64,
    }

    /// The answer to a [`super::coordinator_to_field::SampleBatch`], entry by entry.
    #[derive(Debug, Clone, Copy, ZeroCopySend)]
    #[repr(C)]
    #[type_name("vbap.ReadingBatch.v2")]
    pub struct ReadingBatch {
        pub header: Header,
        /// Sequence number of the request answered.
        pub request_seq: u64,
        /// Number of valid entries in `readings`.
        pub n: u32,
        pub _pad: u32,
        pub readings: [Reading; MAX_VEHICLES],
    }

    impl ReadingBatch {
        /// An empty batch.
        pub fn empty() -> Self {
            Self {
                header: Header::default(),
                request_seq: 0,
                n: 0,
                _pad: 0,
                readings: [Reading::default(); MAX_VEHICLES],
            }
        }
        /// The valid entries.
        pub fn readings(&self) -> &[Reading] {
            &self.readings[..(self.n as usize).min(MAX_VEHICLES)]
        }
    }
}

/// Vehicle → vehicles (`[acoustic]`).
pub mod agent_to_agent {
    use super::*;

    versioned! {
    "vbap.AcousticFrame.v1", RawAcousticFrame;
    /// One acoustic frame of a vehicle's modem (service `<mission>/acoustic`, every agent
    /// publishes and subscribes): `header.sender` the vehicle, `header.tick` the tick of
    /// the state it carries, `header.t` when the frame starts (s). Every agent receives
    /// every frame at once over IPC; the acoustic channel model
    /// (`vbap_mission::acoustic`) decides, in mission time, whether and when each
    /// receiver hears it.
    #[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
    #[repr(C)]
    pub struct AcousticFrame {
        pub header: Header,
        /// The sender's transmission number.
        pub n: u64,
        /// Where the sender truly is (the channel's geometry, not the frame's content),
        /// length unit.
        pub source: [f64; 3],
        /// The believed position the frame carries, length unit.
        pub position: [f64; 3],
        /// The velocity the frame carries, length unit/s.
        pub velocity: [f64; 3],
    }
    }
}

/// Supervisor → coordinator.
pub mod supervisor_to_coordinator {
    use super::*;

    versioned! {
    "vbap.ProcessExit.v1", RawProcessExit;
    /// A supervised process ended (service `<mission>/supervisor/exits`): the supervisor
    /// reaped it, so this is certain knowledge, not a guess from silence. Published at once,
    /// before any restart of that process.
    #[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
    #[repr(C)]
    pub struct ProcessExit {
        pub header: Header,
        /// [`ProcessExit::AGENT`], [`ProcessExit::COORDINATOR`], [`ProcessExit::FIELD_SERVER`],
        /// [`ProcessExit::UNREACHABLE`], or an agent [`ProcessExit::STOPPED`] or
        /// [`ProcessExit::CONTINUED`] (alive: not an exit).
        pub role: u32,
        /// Vehicle id (agents only).
        pub vehicle: u32,
        /// OS process id of the process that ended.
        pub pid: u32,
        /// Signal that killed it (0: it exited by itself).
        pub signal: u32,
        /// Wall-clock time the supervisor reaped it, ns since the Unix epoch (the time of
        /// death within the supervisor's wake-up latency).
        pub died_ns: u64,
    }
    }

    impl ProcessExit {
        /// Role: a vehicle agent.
        pub const AGENT: u32 = 0;
        /// Role: the coordinator.
        pub const COORDINATOR: u32 = 1;
        /// Role: the field server.
        pub const FIELD_SERVER: u32 = 2;
        /// Role: a vehicle agent on another host whose link is gone (its host's bridge
        /// vanished: Zenoh liveliness). Told by this host's bridge, not a supervisor's
        /// reaping: the process may be alive, so its next word is a join request.
        pub const UNREACHABLE: u32 = 3;
        /// Role: a vehicle agent the supervisor saw stopped by a signal (`signal`: SIGSTOP,
        /// SIGTSTP…; `died_ns`: when it saw the stop). Alive, but it will not report until
        /// it is continued: a lockstep coordinator loses it at once rather than wait for
        /// it, and takes its next word as a join request. Local to a host (a bridge does
        /// not forward it).
        pub const STOPPED: u32 = 4;
        /// Role: a vehicle agent [`ProcessExit::STOPPED`] before that runs again (SIGCONT;
        /// `died_ns`: when the supervisor saw it continue).
        pub const CONTINUED: u32 = 5;
    }
}
