//! The neighbours of a [`Guidance`] read from the swarm snapshot of a body command's
//! payload (`vbap_ipc::msg::coordinator_to_agent::SnapshotEntry`).

use vbap_math::rejoin::homing_weight;

use crate::Guidance;

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
