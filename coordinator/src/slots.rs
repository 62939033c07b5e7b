//! What the swarm snapshot tells a vehicle beyond the paper's neighbour positions: the age
//! of the coordinator's information on each member and, under `control.law = "robust"`,
//! every member's own slot (the virtual leader its law falls back on as its neighbours'
//! positions age, `vbap_math::robust`).

use std::collections::BTreeMap;
use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_ipc::msg::from_vec3;

use vbap_math::fit::{held_slots, keep_slots};
use vbap_math::formation::FormationDesign;
use vbap_math::Vec3;

use crate::planner::{Command, Report};

/// Stamps every member's entry of `snapshot` (ordered by id) with the age of the state it
/// holds, s: `(k − tick)·dt` for the command of tick `k` (length `dt`, s), `tick` that of
/// the member's last report in `members` (ordered by id). Other entries keep age 0.
pub fn annotate(snapshot: &mut [SnapshotEntry], k: u64, dt: f64, members: &[Report]) {
    for e in snapshot.iter_mut() {
        if let Ok(i) = members.binary_search_by_key(&e.id, |r| r.id) {
            e.age = k.saturating_sub(members[i].tick) as f64 * dt;
        }
    }
}

/// Every member's slot at the tick of `command` (inertial, length unit), by id: a
/// rejoining member's is the slot it flies to (`command.rejoining`); the others' are the
/// slots of `design`, moved by the command's body in the body's own orientation, assigned
/// to the members' positions as the coordinator knows them, a rejoining member counting at
/// its slot (`vbap_math::fit::held_slots`: each vehicle to a distinct slot). The frame does not turn to fit those positions: they
/// are a round trip old, and a frame turned by them closes a delayed loop on the
/// formation's rotation (s² + K s + κ_s (1 − e^{−sτ}) = 0, unstable once the round trip τ
/// passes about π/√(2 κ_s); docs/ENVELOPE.md).
/// A member left without a slot (more members than slots) has none.
///
/// The assignment changes only when it must: `held` (by id, the slot indices of the last
/// call, forgotten when the formation is redesigned) is kept for every member still
/// within one design spacing of its slot (`vbap_math::fit::keep_slots`), and updated.
/// Assigned afresh each tick, a member thrown 0.3 spacing off its slot lost it to a
/// neighbour and was sent two slots round the ring, through its neighbours (a near
/// collision at 0.008 spacing; docs/STRESS.md, tenth stop).
pub fn member_slots(
    design: &FormationDesign,
    held: &mut BTreeMap<u32, usize>,
    command: &Command,
    members: &[Report],
) -> Vec<(u32, Vec3)> {
    let body = &command.body;
    if command.reconfigured {
        held.clear();
    }
    // A rejoining member counts at the slot it flies to, so that no other member is
    // assigned that slot: where it was admitted back (its hull) may be next to a member
    // that the formation carried into its old hole, which then took the slot given to the
    // rejoining vehicle, and the two met there once it was captured (stress seed 13,
    // m0905: a near collision at 0.03 spacing).
    let positions: Vec<Vec3> = members
        .iter()
        .map(|r| {
            command
                .rejoining
                .iter()
                .find(|(id, _)| *id == r.id)
                .map_or(r.position, |(_, target)| *target)
        })
        .collect();
    // The body's own orientation: the frame `held_slots` assigns in (it never turns).
    let rotation = *body.rotation.matrix();
    let last: Vec<Option<usize>> = members.iter().map(|r| held.get(&r.id).copied()).collect();
    let slots = keep_slots(&positions, design, body, &rotation, &last, || {
        held_slots(&positions, design, body, design.dim).slot
    });
    *held = members
        .iter()
        .zip(&slots)
        .filter_map(|(r, s)| s.map(|j| (r.id, j)))
        .collect();
    members
        .iter()
        .zip(&slots)
        .filter_map(|(r, slot)| {
            if let Some((_, target)) = command.rejoining.iter().find(|(id, _)| *id == r.id) {
                return Some((r.id, *target));
            }
            let p = design.slots.get((*slot)?)?;
            Some((r.id, body.r + rotation * (body.scale * p)))
        })
        .collect()
}

/// Writes `slots` (by id) into the entries of `snapshot`.
pub fn give_slots(snapshot: &mut [SnapshotEntry], slots: &[(u32, Vec3)]) {
    for (id, slot) in slots {
        if let Some(e) = snapshot.iter_mut().find(|e| e.id == *id) {
            e.slot = from_vec3(slot);
            e.has_slot = 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vbap_math::body::VirtualBody;
    use vbap_math::formation::design_regular;

    #[test]
    fn ages_count_from_each_members_last_report() {
        let report = |id, tick| Report {
            id,
            tick,
            position: Vec3::zeros(),
            velocity: Vec3::zeros(),
            measurement: 0.0,
        };
        let members = [report(0, 10), report(2, 7)];
        let mut snapshot: Vec<SnapshotEntry> = [0, 1, 2]
            .iter()
            .map(|&id| SnapshotEntry {
                id,
                ..SnapshotEntry::default()
            })
            .collect();
        annotate(&mut snapshot, 10, 0.5, &members);
        let ages: Vec<f64> = snapshot.iter().map(|e| e.age).collect();
        assert_eq!(ages, vec![0.0, 0.0, 1.5]);
    }

    /// A command of `body` for the members 0..n of `design`, nobody rejoining.
    fn command(design: &FormationDesign, body: VirtualBody, reconfigured: bool) -> Command {
        Command {
            body,
            sdot: 0.0,
            velocity: Vec3::zeros(),
            leaders: vec![],
            inter: design.inter,
            leader: design.leader,
            damping: 1.0,
            terms: Default::default(),
            grad_est: Vec3::zeros(),
            p_trace: 0.0,
            holding: false,
            estimate_failed: false,
            reconfigured,
            members: (0..design.slots.len() as u32).collect(),
            rejoining: vec![],
            schedule: None,
        }
    }

    /// A body at (3, −1) in its own frame, scale 1.
    fn body_off_origin() -> VirtualBody {
        VirtualBody {
            s: 0.0,
            r: Vec3::new(3.0, -1.0, 0.0),
            rotation: nalgebra::Rotation3::identity(),
            scale: 1.0,
        }
    }

    /// Members at `positions`, ids 0.. in order.
    fn members_at(positions: &[Vec3]) -> Vec<Report> {
        positions
            .iter()
            .enumerate()
            .map(|(i, x)| Report {
                id: i as u32,
                tick: 0,
                position: *x,
                velocity: Vec3::zeros(),
                measurement: 0.0,
            })
            .collect()
    }

    /// Vehicles 0 and 1 of a hexagon thrown 0.6 of the way towards each other's slot:
    /// assigned afresh they swap slots; with the last assignment held they keep theirs;
    /// at a redesign the held assignment is forgotten and they are assigned afresh.
    #[test]
    fn a_held_assignment_is_kept_until_a_redesign() {
        let design = design_regular(6, 2, 1.5, 1.0, 1.0).unwrap();
        let body = body_off_origin();
        let at = |j: usize| body.r + design.slots[j];
        let own: Vec<(u32, Vec3)> = (0..6).map(|j| (j as u32, at(j))).collect();
        let mut thrown: Vec<Vec3> = (0..6).map(at).collect();
        thrown[0] += 0.6 * (at(1) - at(0));
        thrown[1] += 0.6 * (at(0) - at(1));
        let steady = command(&design, body, false);
        // Afresh (nothing held): swapped.
        let fresh = member_slots(&design, &mut BTreeMap::new(), &steady, &members_at(&thrown));
        assert_eq!((fresh[0].1, fresh[1].1), (at(1), at(0)), "swapped afresh");
        // Held from a tick at the slots: kept.
        let mut held = BTreeMap::new();
        let at_slots: Vec<Vec3> = (0..6).map(at).collect();
        assert_eq!(
            member_slots(&design, &mut held, &steady, &members_at(&at_slots)),
            own
        );
        assert_eq!(held, (0..6).map(|j| (j as u32, j)).collect());
        assert_eq!(
            member_slots(&design, &mut held, &steady, &members_at(&thrown)),
            own,
            "kept"
        );
        // A redesign forgets it.
        let redesigned = command(&design, body, true);
        assert_eq!(
            member_slots(&design, &mut held, &redesigned, &members_at(&thrown)),
            fresh
        );
        assert_eq!(held[&0], 1, "the fresh assignment is held from now on");
    }

    /// Vehicle 2 is admitted back at its old slot 2 (where it died), given slot 3 to fly
    /// to; vehicle 3 sits in slot 2 (a fifth of the way to slot 3). Assigned by where the
    /// vehicles are, 3 would take slot 3, the rejoining vehicle's: the two would meet
    /// there. The rejoining vehicle counts at its slot, so 3 keeps slot 2.
    #[test]
    fn no_member_is_given_the_slot_a_rejoining_vehicle_flies_to() {
        let design = design_regular(6, 2, 1.5, 1.0, 1.0).unwrap();
        let body = body_off_origin();
        let at = |j: usize| body.r + design.slots[j];
        let mut positions: Vec<Vec3> = (0..6).map(at).collect();
        positions[3] = at(2) + 0.2 * (at(3) - at(2));
        let mut command = command(&design, body, true);
        command.rejoining = vec![(2, at(3))];
        let slots = member_slots(
            &design,
            &mut BTreeMap::new(),
            &command,
            &members_at(&positions),
        );
        assert_eq!(slots[2], (2, at(3)), "the rejoining vehicle's target");
        assert_eq!(slots[3], (3, at(2)), "not the rejoining vehicle's slot");
    }

    #[test]
    fn members_in_a_turned_polygon_get_the_slots_of_the_bodys_own_frame() {
        // A hexagon turned by 0.2 rad about its centre, vehicles a little off their slots:
        // each gets its own vertex of the turned hexagon.
        let design = design_regular(6, 2, 1.5, 1.0, 1.0).unwrap();
        let body = body_off_origin();
        let turn = nalgebra::Rotation3::from_axis_angle(&Vec3::z_axis(), 0.2);
        let truth: Vec<Vec3> = design.slots.iter().map(|p| body.r + turn * p).collect();
        let near: Vec<Vec3> = (0..6)
            .map(|i| truth[i] + Vec3::new(0.05, -0.03 * i as f64, 0.0))
            .collect();
        let members = members_at(&near);
        let mut command = command(&design, body, false);
        command.rejoining = vec![(5, Vec3::new(9.0, 9.0, 0.0))];
        let slots = member_slots(&design, &mut BTreeMap::new(), &command, &members);
        assert_eq!(slots.len(), 6);
        // The frame is the body's own: turning it to fit the (stale) positions would feed
        // the formation's rotation back through the links' delay.
        for (id, slot) in &slots[..5] {
            let own = body.r + design.slots[*id as usize];
            assert_eq!(*slot, own, "vehicle {id}: its slot in the body's frame");
        }
        assert_eq!(
            slots[5],
            (5, Vec3::new(9.0, 9.0, 0.0)),
            "a rejoiner's target"
        );
    }
}
