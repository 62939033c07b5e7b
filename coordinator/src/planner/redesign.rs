//! The formation's membership at a tick: a redesign when the members change, the
//! vehicles that must fly back to a slot (`vbap_math::rejoin`), and their slots.
//!
//! Under `[control] law = "robust"` a redesign is bumpless (beyond the paper, which
//! keeps the body as it was and lets the new design start far from its equilibrium): the
//! new design is laid on the vehicles that hold the formation (`vbap_math::bumpless`: the
//! optimal assignment of vehicles to slots and the pose `(r, R, k)` with the least `V`),
//! every vehicle still to be placed is given a free slot by the optimal assignment, and
//! the body holds (`ṡ = 0`) until the coordinator's `V` is back at or below `V_U`.

use std::collections::BTreeMap;

use vbap_math::assign::assign_nearest;
use vbap_math::body::VirtualBody;
use vbap_math::bumpless::bumpless_body;
use vbap_math::fit::held_slots;
use vbap_math::formation::{design_regular, FormationDesign};
use vbap_math::rejoin::{choose_slot, clearance, fit_turn, homing_weight, turned_slots, FREE};
use vbap_math::Vec3;
use vbap_mission::config::LawKind;

use super::{Planner, PlannerError, Report};

impl Planner {
    /// [`Planner::follow_membership`] for the `members` of this tick (ordered by id; their
    /// ids `ids`) and the vehicles `joined`; under law robust a redesign is then laid on
    /// the vehicles ([`Planner::lay_new_design`]). True when it was redesigned.
    pub(super) fn redesign(
        &mut self,
        members: &[Report],
        ids: &[u32],
        joined: &[u32],
    ) -> Result<bool, PlannerError> {
        // The vehicles that held the old formation and are still in it: members before
        // and after, not rejoining, not admitted back at this tick.
        let anchors: Vec<u32> = ids
            .iter()
            .copied()
            .filter(|id| {
                self.members.contains(id)
                    && !self.rejoining.contains_key(id)
                    && !joined.contains(id)
            })
            .collect();
        if self.params.law == LawKind::Robust && !members.is_empty() {
            if let Some(changed) = self.keep_design_with_holes(members, ids, joined, &anchors) {
                return Ok(changed);
            }
        }
        let reconfigured = self.follow_membership(ids, members.is_empty(), joined)?;
        if reconfigured && self.params.law == LawKind::Robust && !members.is_empty() {
            self.lay_new_design(members, &anchors);
        }
        Ok(reconfigured)
    }

    /// A change of the `members` (ids `ids`; `joined` admitted back at this tick) that the
    /// design in force can hold, under law robust (beyond the paper): the vehicles that
    /// hold the formation (`anchors`) keep their slots of the design the formation had
    /// before it lost anyone (`base`), every other member (back or new) is given the free
    /// slot nearest to it (optimal assignment), and the slots nobody holds are left empty
    /// (`FormationDesign::without_slots`). The body is not moved: the anchors stay at an
    /// equilibrium, so a loss moves no slot and costs no V; a vehicle that comes back
    /// flies home to a hole (`vbap_math::rejoin`) and enters V in full only near it.
    /// Some(true) when the members changed, Some(false) when not; None when the design
    /// cannot hold them (more members than its slots, an anchor without a slot): then
    /// the formation is redesigned.
    fn keep_design_with_holes(
        &mut self,
        members: &[Report],
        ids: &[u32],
        joined: &[u32],
        anchors: &[u32],
    ) -> Option<bool> {
        if !self.members_changed(ids, joined) {
            return Some(false);
        }
        let base = self.base.clone().unwrap_or_else(|| self.design.clone());
        if ids.len() > base.n() || anchors.is_empty() {
            return None;
        }
        let (held, others): (Vec<&Report>, Vec<&Report>) =
            members.iter().partition(|q| anchors.contains(&q.id));
        let positions: Vec<Vec3> = held.iter().map(|q| q.position).collect();
        let fit = held_slots(&positions, &base, &self.body, base.dim);
        let mut taken: Vec<usize> = fit.slot.iter().flatten().copied().collect();
        if taken.len() != held.len() {
            return None;
        }
        let all = self.body.slot_positions(&base);
        let free: Vec<usize> = (0..base.n()).filter(|m| !taken.contains(m)).collect();
        // A hole with a lost vehicle's hull in it is left to that vehicle, while there
        // are other holes for the ones that come back (`update_rejoining`).
        let spacing = self.body.scale * base.neighbour_spacing();
        let open: Vec<usize> = free
            .iter()
            .copied()
            .filter(|&m| clearance(&all[m], &self.hulls) >= FREE * spacing)
            .collect();
        let free = if open.len() >= others.len() {
            open
        } else {
            free
        };
        let free_slots: Vec<Vec3> = free.iter().map(|&m| all[m]).collect();
        let from: Vec<Vec3> = others.iter().map(|q| q.position).collect();
        taken.extend(
            assign_nearest(&from, &free_slots)?
                .into_iter()
                .map(|j| free[j]),
        );
        let holes: Vec<usize> = (0..base.n()).filter(|m| !taken.contains(m)).collect();
        self.design = base.without_slots(&holes);
        self.base = (!holes.is_empty()).then_some(base);
        self.holes = holes;
        self.mark_rejoining(ids, joined);
        self.members = ids.to_vec();
        self.reconfigurations += 1;
        Some(true)
    }

    /// True when the members `ids` of this tick differ from the formation's, or one of the
    /// vehicles `joined` (admitted back at this tick) is among them.
    fn members_changed(&self, ids: &[u32], joined: &[u32]) -> bool {
        ids != self.members.as_slice() || joined.iter().any(|id| ids.contains(id))
    }

    /// A vehicle that becomes a member after the start, or is admitted back (also when
    /// lost at this very tick), comes back from wherever it is: it rejoins. Only members
    /// `ids` rejoin, and every rejoining vehicle's slot is chosen again.
    fn mark_rejoining(&mut self, ids: &[u32], joined: &[u32]) {
        for id in ids {
            if !self.members.contains(id) || joined.contains(id) {
                self.rejoining.insert(*id, None);
            }
        }
        self.rejoining.retain(|id, _| ids.contains(id));
        for slot in self.rejoining.values_mut() {
            *slot = None;
        }
    }

    /// Lays the new design on the `anchors` (ids of the vehicles that hold the formation)
    /// among the `members` of this tick (law robust, beyond the paper): the body takes the
    /// pose of `vbap_math::bumpless::bumpless_body` (scale within [min_scale,
    /// max_scale], in 2-D about z only, `s` kept), the turn of the slots is reset to the
    /// body's, every rejoining anchor keeps the slot it was assigned, the other rejoining
    /// vehicles share the free slots by the optimal assignment (least sum of squared
    /// distances), and the body holds until `V ≤ V_U` ([`Planner::hold_until_settled`]).
    /// Without anchors the body is kept.
    fn lay_new_design(&mut self, members: &[Report], anchors: &[u32]) {
        self.settling = true;
        let (held, rest): (Vec<&Report>, Vec<&Report>) =
            members.iter().partition(|q| anchors.contains(&q.id));
        if held.is_empty() {
            return;
        }
        let p = &self.params;
        let positions: Vec<Vec3> = held.iter().map(|q| q.position).collect();
        let velocities: Vec<Vec3> = held.iter().map(|q| q.velocity).collect();
        let movers: Vec<&Report> = rest
            .into_iter()
            .filter(|q| self.rejoining.contains_key(&q.id))
            .collect();
        let from: Vec<Vec3> = movers.iter().map(|q| q.position).collect();
        // Poses within a tenth of V_U of the least energy count as equally good: of those,
        // the one that leaves its free slots on the movers' side.
        let (mut body, _, slots) = bumpless_body(
            &positions,
            &velocities,
            &from,
            &self.design,
            &self.body,
            (p.min_scale, p.max_scale),
            p.damping,
            0.1 * p.v_u,
        );
        if p.dim == 2 {
            body.r.z = 0.0;
        }
        self.jumps += body.r - self.body.r;
        self.body = body;
        self.turn = 0.0;
        for (q, &m) in held.iter().zip(&slots) {
            if let Some(slot) = self.rejoining.get_mut(&q.id) {
                *slot = Some(m);
            }
        }
        let all = body.slot_positions(&self.design);
        let free: Vec<usize> = (0..all.len()).filter(|m| !slots.contains(m)).collect();
        let free_slots: Vec<Vec3> = free.iter().map(|&m| all[m]).collect();
        if let Some(pi) = assign_nearest(&from, &free_slots) {
            for (q, j) in movers.iter().zip(pi) {
                self.rejoining.insert(q.id, Some(free[j]));
            }
        }
    }

    /// The body's speed `sdot` (1/s) after a bumpless redesign (law robust, beyond the
    /// paper): 0 while the coordinator's `V` (`v`, energy per unit mass) is above `V_U`,
    /// from the redesign until the first tick it is not; `sdot` unchanged otherwise. The
    /// paper needs no such hold (its `V ≤ V_U` is never broken by a switch it does not
    /// have); here the new design may start with `V > V_U`, and (IV.4)'s second term could
    /// still move the body on while the formation settles.
    pub(super) fn hold_until_settled(&mut self, v: f64, sdot: f64) -> f64 {
        if !self.settling {
            return sdot;
        }
        if v <= self.params.v_u {
            self.settling = false;
            return sdot;
        }
        0.0
    }

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
        if !self.members_changed(ids, joined) {
            return Ok(false);
        }
        self.mark_rejoining(ids, joined);
        let p = &self.params;
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
        if !self.rejoining.is_empty() && !self.design.is_central() {
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
    /// design, a slot with a lost vehicle's hull in it (`hulls`, where each was last heard
    /// of) counting as taken; the slots move with the body and, for a 2-D central design,
    /// follow the settled members as they turn about the centre (`turn`). Returns the
    /// slots (inertial), by id.
    ///
    /// Why the hulls: a loss leaves a hole, and a vehicle that came back took the nearest
    /// hole, which may be another lost vehicle's; that one's process, restarted where its
    /// hull had stayed, came back 0.03 spacing from it, and their repulsion threw it 60
    /// spacings (stress seed 17, m0927: true V 1300 V_U).
    pub(super) fn update_rejoining(
        rejoining: &mut BTreeMap<u32, Option<usize>>,
        turn: &mut f64,
        design: &FormationDesign,
        body: &VirtualBody,
        members: &[Report],
        hulls: &[Vec3],
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
        occupants.extend_from_slice(hulls);
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
