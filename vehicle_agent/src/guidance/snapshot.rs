//! The neighbours of a [`Guidance`] read from the swarm snapshot of a body command's
//! payload (`vbap_ipc::msg::coordinator_to_agent::SnapshotEntry`).

use vbap_ipc::compact::{command_len, Precision};
use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_ipc::msg::{from_vec3, to_vec3};
use vbap_math::neighbourhood::{reach, within};
use vbap_math::rejoin::homing_weight;
use vbap_math::Vec3;

use crate::Guidance;

/// What one body command tells one vehicle ([`Guidance::tell`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ToldCommand {
    /// Its guidance (without the body path: [`Guidance::with_plan`]).
    pub guidance: Guidance,
    /// Its own entry of the command's snapshot, as its link carries it.
    pub own: Option<SnapshotEntry>,
    /// The size of the command it is told in the compact link encoding, bytes.
    pub bytes: u64,
}

/// How what a vehicle is told crosses its link: the longest it flies on one command, and
/// the precision of the positions and velocities (`links.position_quantum`) relative to
/// the body centre `origin` of the command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Telling {
    /// The longest the vehicle may fly on one command, s
    /// (`vbap_mission::horizon::plan_horizon`).
    pub horizon: f64,
    /// Exact, or quantised (`vbap_wire::compact`).
    pub precision: Precision,
    /// The command's body centre r, length unit.
    pub origin: Vec3,
}

impl Telling {
    /// `v` as the link carries it (relative to `origin`; exact when the quantum cannot hold
    /// it: such a value could not be sent, and is kept as it is).
    fn round_trip(&self, v: &[f64; 3], origin: &[f64; 3]) -> [f64; 3] {
        self.precision.round_trip(v, origin).unwrap_or(*v)
    }

    /// Entry `e` as the link carries it: positions relative to the body centre, velocities
    /// absolute (`own`: the vehicle's own entry, whose slot is carried too).
    fn as_read(&self, e: &SnapshotEntry, own: bool) -> SnapshotEntry {
        if self.precision == Precision::Exact {
            return *e;
        }
        let origin = from_vec3(&self.origin);
        SnapshotEntry {
            position: self.round_trip(&e.position, &origin),
            velocity: self.round_trip(&e.velocity, &[0.0; 3]),
            target: if e.rejoining != 0 {
                self.round_trip(&e.target, &origin)
            } else {
                e.target
            },
            slot: if own && e.has_slot != 0 {
                self.round_trip(&e.slot, &origin)
            } else {
                e.slot
            },
            ..*e
        }
    }
}

impl Guidance {
    /// This guidance for vehicle `id` of a body command: as neighbours every member or
    /// admitted vehicle of the command's snapshot but itself, each with its homing weight
    /// σ_j (from its position and slot, for the spacing `inter.d0`); its own slot when it
    /// rejoins; as hulls the positions of the lost vehicles but itself.
    ///
    /// The per-neighbour vectors a law may receive empty
    /// ([`ControlInputs`](crate::ControlInputs)) stay empty when they would hold nothing
    /// else: `neighbour_sigmas` and `neighbour_slots` while no neighbour rejoins (every
    /// σ_j = 0, every slot its position), `neighbour_ages` while every age is exactly +0 s.
    /// Every law reads them with those defaults, so u_i is the same bit for bit (test
    /// `compact_guidance_flies_as_the_full_one`); the vehicle copies two vectors per command
    /// instead of five (each agent reads the whole snapshot every tick: this copy was its
    /// largest cost at N = 1024).
    pub fn with_neighbours(self, id: u32, snapshot: &[SnapshotEntry]) -> Self {
        self.with_neighbours_and_own(id, snapshot).0
    }

    /// This guidance for vehicle `id` of a body command whose snapshot is `snapshot`, as the
    /// command tells it: from its own entry `own` (an index of `snapshot`, see
    /// `BodyCommand::own_index`; None: the snapshot has none) and the entries of its
    /// neighbour list `near` (indices of `snapshot`, ascending: `vbap_coordinator::near`)
    /// only, never the whole snapshot. Those entries are read as
    /// [`Guidance::with_neighbours_and_own`] reads a snapshot; the leaders kept are those
    /// within reach of the vehicle's entry (`vbap_math::neighbourhood::reach` of the
    /// scaled `h1`, `h0`: the paper's ball of radius `h1` and a margin, and how far the
    /// vehicle may move relative to the body flying on commands for up to `horizon` s,
    /// `SnapshotEntry::drift_margin`), all of them when it has no entry. Positions
    /// and velocities are read at the precision of the vehicle's link (`link`,
    /// `links.position_quantum`): as its compact encoding would carry them.
    pub fn with_near(
        self,
        id: u32,
        snapshot: &[SnapshotEntry],
        own: Option<usize>,
        near: impl IntoIterator<Item = usize>,
        link: &Telling,
    ) -> (Self, Option<SnapshotEntry>) {
        let told = self.tell(id, snapshot, own, near, link, None);
        (told.guidance, told.own)
    }

    /// [`Guidance::with_near`], and the size of what the vehicle is told in the compact
    /// link encoding (`vbap_ipc::compact::command_len`) when the command carries a body
    /// path of `plan` segments (None: no path), from the same pass: the one place a
    /// command is turned into what one vehicle reads (the agents and the in-process
    /// simulator alike).
    pub fn tell(
        mut self,
        id: u32,
        snapshot: &[SnapshotEntry],
        own: Option<usize>,
        near: impl IntoIterator<Item = usize>,
        link: &Telling,
        plan: Option<usize>,
    ) -> ToldCommand {
        let own = own
            .and_then(|i| snapshot.get(i))
            .map(|e| link.as_read(e, true));
        let mut told: Vec<SnapshotEntry> = near
            .into_iter()
            .filter_map(|j| snapshot.get(j))
            .filter(|e| e.id != id)
            .map(|e| link.as_read(e, false))
            .collect();
        if link.precision != Precision::Exact {
            let origin = from_vec3(&link.origin);
            for b in &mut self.leaders {
                *b = to_vec3(&link.round_trip(&from_vec3(b), &origin));
            }
        }
        if let Some(own) = own {
            let x = to_vec3(&own.position);
            let margin = own.drift_margin(&self.velocity, link.horizon);
            let r = reach(self.leader.d1, self.leader.d0) + margin;
            let kept = within(&self.leaders, &x, r);
            if kept.len() < self.leaders.len() {
                self.leaders = kept.iter().map(|&l| self.leaders[l as usize]).collect();
            }
        }
        let bytes = command_len(
            plan,
            self.leaders.len(),
            own.as_ref(),
            &told,
            link.precision,
        );
        if let Some(own) = own {
            let at = told.partition_point(|e| e.id < own.id);
            told.insert(at, own);
        }
        let (guidance, own) = self.with_neighbours_and_own(id, &told);
        ToldCommand {
            guidance,
            own,
            bytes: bytes as u64,
        }
    }

    /// [`Guidance::with_neighbours`], and the first entry of the snapshot with this
    /// vehicle's id whatever its state (how a rejoining vehicle learns it is admitted), from
    /// the same pass.
    pub fn with_neighbours_and_own(
        mut self,
        id: u32,
        snapshot: &[SnapshotEntry],
    ) -> (Self, Option<SnapshotEntry>) {
        let spacing = self.inter.d0;
        let n = snapshot.len();
        self.neighbours = Vec::with_capacity(n);
        self.neighbour_ids = Vec::with_capacity(n);
        self.neighbour_velocities = Vec::with_capacity(n);
        self.neighbour_sigmas = Vec::new();
        self.neighbour_slots = Vec::new();
        self.neighbour_ages = Vec::new();
        self.hulls = Vec::new();
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
                self.hulls.push(to_vec3(&e.position));
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
            self.neighbour_ids.push(e.id);
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
}
