//! The formation's membership at a tick: a redesign when the members change, the
//! vehicles that must fly back to a slot (`vbap_math::rejoin`), and their slots.

use std::collections::BTreeMap;

use vbap_math::body::VirtualBody;
use vbap_math::formation::{design_regular, FormationDesign};
use vbap_math::rejoin::{
    choose_slot, clearance, fit_turn, homing_weight, is_central, turned_slots,
};
use vbap_math::Vec3;

use super::{Planner, PlannerError, Report};

impl Planner {
    /// Follows the members `ids` of this tick (ordered by id; `none`: no member report
    /// at all) and the vehicles `joined` (admitted back at this tick): when the members
    /// changed or one was admitted back, the formation is redesigned (a regular design of
    /// (III.3) for the new count, unless there is no member) and every rejoining vehicle's
    /// slot is chosen again. True when it was redesigned.
    pub(super) fn follow_membership(
        &mut self,
        ids: &[u32],
        none: bool,
        joined: &[u32],
    ) -> Result<bool, PlannerError> {
        let p = &self.params;
        let rejoined = joined.iter().any(|id| ids.contains(id));
        if ids == self.members.as_slice() && !rejoined {
            return Ok(false);
        }
        // A vehicle that becomes a member after the start, or is admitted back (also
        // when lost at this very tick), comes back from wherever it is: it rejoins.
        // Every slot is chosen again.
        for id in ids {
            if !self.members.contains(id) || joined.contains(id) {
                self.rejoining.insert(*id, None);
            }
        }
        self.rejoining.retain(|id, _| ids.contains(id));
        for slot in self.rejoining.values_mut() {
            *slot = None;
        }
        if !none {
            self.design =
                design_regular(ids.len(), p.dim, p.radius, p.alpha, p.alpha).map_err(|source| {
                    PlannerError::Design {
                        n: ids.len(),
                        source,
                    }
                })?;
        }
        self.members = ids.to_vec();
        self.reconfigurations += 1;
        if !self.rejoining.is_empty() && !is_central(&self.design) {
            // A design with a leader group per slot holds each vehicle only near its
            // own slot: when a vehicle comes back, the others (arranged for the old
            // design) are given slots of the new one too; those already in one are
            // captured at once and fly (II.1) as before.
            for id in ids {
                self.rejoining.insert(*id, None);
            }
        }
        Ok(true)
    }

    /// A member out of every leader's reach (farther than the scaled leader potential's
    /// d1 from every virtual leader b_l (III.3), length unit; thrown out by a
    /// near-collision, or adrift with stale guidance) feels no force of (II.1) at all: it
    /// is brought back the way a returning vehicle is.
    pub(super) fn bring_back_out_of_reach(&mut self, members: &[Report]) {
        let leaders = self.body.leader_positions(&self.design);
        let reach = self.body.scaled_leader(&self.design).d1;
        for q in members {
            if !self.rejoining.contains_key(&q.id)
                && leaders.iter().all(|b| (q.position - b).norm() >= reach)
            {
                self.rejoining.insert(q.id, None);
            }
        }
    }

    /// Brings the rejoining members up to date at this tick (`vbap_math::rejoin`):
    /// every vehicle that became a member after the start rejoins until its last known
    /// position is within the capture radius of its slot. Its slot is chosen once (when it
    /// joins, or again when the formation is redesigned): the nearest free slot of the
    /// design; the slots move with the body and, for a 2-D central design, follow the
    /// settled members as they turn about the centre (`turn`). Returns the slots
    /// (inertial), by id.
    pub(super) fn update_rejoining(
        rejoining: &mut BTreeMap<u32, Option<usize>>,
        turn: &mut f64,
        design: &FormationDesign,
        body: &VirtualBody,
        members: &[Report],
    ) -> Vec<(u32, Vec3)> {
        if rejoining.is_empty() {
            return Vec::new();
        }
        let spacing = body.scale * design.neighbour_spacing();
        let settled: Vec<Vec3> = members
            .iter()
            .filter(|q| !rejoining.contains_key(&q.id))
            .map(|q| q.position)
            .collect();
        *turn = fit_turn(design, body, &settled, *turn);
        let slots = turned_slots(design, body, *turn);
        let mut occupants = settled;
        occupants.extend(rejoining.values().flatten().filter_map(|m| slots.get(*m)));
        // Slots are given out nearest first: the vehicles closest to a slot choose first
        // (ties by id), so a vehicle already in a slot keeps it.
        let mut unassigned: Vec<(f64, u32, Vec3)> = members
            .iter()
            .filter(|q| rejoining.get(&q.id).is_some_and(|s| s.is_none()))
            .map(|q| (clearance(&q.position, &slots), q.id, q.position))
            .collect();
        unassigned.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, id, x) in unassigned {
            if let Some(m) = choose_slot(&slots, &occupants, &x, spacing) {
                occupants.push(slots[m]);
                rejoining.insert(id, Some(m));
            }
        }
        let mut targets = Vec::new();
        for q in members {
            let Some(slot) = rejoining.get(&q.id) else {
                continue;
            };
            let Some(target) = slot.and_then(|m| slots.get(m).copied()) else {
                continue;
            };
            if homing_weight((q.position - target).norm(), spacing) == 0.0 {
                // Captured: an ordinary member from now on.
                rejoining.remove(&q.id);
                continue;
            }
            targets.push((q.id, target));
        }
        targets
    }
}
