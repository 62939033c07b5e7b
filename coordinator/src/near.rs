//! Whom each vehicle is told of: the entries of the swarm snapshot within reach of each
//! entry (`vbap_math::neighbourhood`), published with the command as one list per entry, so
//! that a vehicle reads its own few neighbours and never the whole fleet.
//!
//! A rejoining vehicle counts both where it is and at the slot it flies to: its neighbours'
//! law pulls them towards that slot's ghost (`vbap_math::rejoin`), which may be far from the
//! vehicle itself.

use vbap_ipc::compact::{command_len, Precision};
use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_ipc::msg::to_vec3;
use vbap_math::neighbourhood::{reach, within, Neighbourhoods};

use crate::planner::Command;
use vbap_math::potential::PairPotential;
use vbap_math::Vec3;

/// The neighbour lists of `snapshot` (snapshot indices, ascending) for the scaled
/// inter-vehicle potential `inter`, a body moving at `body_velocity` (length/s) and
/// commands flown for up to `horizon` s: for entry `i`, every other entry `j` whose
/// position, or slot when it rejoins, is within [`reach`]`(d1, d0)` of entry `i`'s
/// position plus both drift margins (`SnapshotEntry::drift_margin`) (a slot is body-fixed: no margin of its own); at
/// most `vbap_math::neighbourhood::MAX_NEAR`, the nearest.
pub fn neighbour_lists(
    snapshot: &[SnapshotEntry],
    inter: &PairPotential,
    body_velocity: &Vec3,
    horizon: f64,
) -> Neighbourhoods {
    let n = snapshot.len();
    let mut points: Vec<Vec3> = snapshot.iter().map(|e| to_vec3(&e.position)).collect();
    let mut margins: Vec<f64> = snapshot
        .iter()
        .map(|e| e.drift_margin(body_velocity, horizon))
        .collect();
    // The slots of the rejoining entries, after the positions, and whose they are.
    let mut owner: Vec<u32> = (0..n as u32).collect();
    for (i, e) in snapshot.iter().enumerate() {
        if e.rejoining != 0 && e.alive != SnapshotEntry::LOST {
            points.push(to_vec3(&e.target));
            margins.push(0.0);
            owner.push(i as u32);
        }
    }
    let by_point = Neighbourhoods::with_margins(&points, reach(inter.d1, inter.d0), &margins);
    if points.len() == n {
        return by_point;
    }
    let mut lists = Neighbourhoods {
        starts: Vec::with_capacity(n + 1),
        near: Vec::with_capacity(by_point.near.len()),
    };
    lists.starts.push(0);
    let mut list: Vec<u32> = Vec::new();
    for i in 0..n {
        list.clear();
        list.extend(
            by_point
                .of_point(i)
                .iter()
                .map(|&p| owner[p as usize])
                .filter(|&j| j as usize != i),
        );
        list.sort_unstable();
        list.dedup();
        lists.near.extend_from_slice(&list);
        lists.starts.push(lists.near.len() as u32);
    }
    lists
}

/// The sizes of one tick's commands on the vehicles' own links.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CommandSizes {
    /// Commands (one per vehicle that is not lost and can hear).
    pub count: u64,
    /// Their bytes, summed.
    pub bytes: u64,
    /// The largest, bytes.
    pub max: u64,
    /// Those over the link's per-message limit (Iridium's `down_limit`): split or refused.
    pub over_limit: u64,
}

/// The size of the command of `command` each vehicle of `snapshot` (not lost, and in contact:
/// `in_contact` of its id; a submerged glider hears nothing) is told, in the compact link
/// encoding ([`vbap_wire::compact`], at `precision`): its own entry, the entries
/// of its list in `lists` (other vehicles'), the leaders within its reach
/// plus its drift margin (`SnapshotEntry::drift_margin`; `vehicle_agent::Guidance::with_near` keeps the same; commands
/// flown for up to `horizon` s) and the committed path; those over `limit` bytes counted.
pub fn command_sizes(
    command: &Command,
    snapshot: &[SnapshotEntry],
    lists: &Neighbourhoods,
    horizon: f64,
    precision: Precision,
    in_contact: impl Fn(u32) -> bool,
    limit: Option<u64>,
) -> CommandSizes {
    let plan = command.schedule.as_ref().map(|s| s.segments.len());
    let leader_reach = reach(command.leader.d1, command.leader.d0);
    let mut sizes = CommandSizes::default();
    let mut told: Vec<SnapshotEntry> = Vec::new();
    for (i, own) in snapshot.iter().enumerate() {
        if own.alive == SnapshotEntry::LOST
            || vbap_ipc::msg::coordinator_to_agent::own_index(snapshot, own.id) != Some(i)
            || !in_contact(own.id)
        {
            continue;
        }
        told.clear();
        told.extend(
            lists
                .of_point(i)
                .iter()
                .map(|&j| snapshot[j as usize])
                .filter(|e| e.id != own.id),
        );
        let margin = own.drift_margin(&command.velocity, horizon);
        let x = to_vec3(&own.position);
        let leaders = within(&command.leaders, &x, leader_reach + margin).len();
        let b = command_len(plan, leaders, Some(own), &told, precision) as u64;
        sizes.count += 1;
        sizes.bytes += b;
        sizes.max = sizes.max.max(b);
        sizes.over_limit += u64::from(limit.is_some_and(|l| b > l));
    }
    sizes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(id: u32, x: f64) -> SnapshotEntry {
        SnapshotEntry {
            id,
            alive: SnapshotEntry::MEMBER,
            position: [x, 0.0, 0.0],
            ..SnapshotEntry::default()
        }
    }

    /// A row spaced 1 with d1 = 1.5 (reach 2): each hears of the two on each side; a
    /// rejoining vehicle far off is heard of by those near the slot it flies to, and hears
    /// of them.
    #[test]
    fn a_vehicle_hears_of_its_near_neighbours_and_of_a_rejoining_one_by_its_slot() {
        let inter = PairPotential::new(1.0, 1.0, 1.5).unwrap();
        let mut snapshot: Vec<SnapshotEntry> = (0..6).map(|i| entry(i, i as f64)).collect();
        let still = Vec3::zeros();
        let lists = neighbour_lists(&snapshot, &inter, &still, 0.0);
        assert_eq!(lists.of_point(0), &[1, 2]);
        assert_eq!(lists.of_point(3), &[1, 2, 4, 5]);
        snapshot.push(SnapshotEntry {
            rejoining: 1,
            target: [5.5, 0.0, 0.0],
            ..entry(6, 40.0)
        });
        let lists = neighbour_lists(&snapshot, &inter, &still, 0.0);
        assert_eq!(lists.of_point(5), &[3, 4, 6]);
        assert_eq!(lists.of_point(0), &[1, 2]);
        assert_eq!(lists.of_point(6), &[] as &[u32]);
        assert_eq!(lists.starts.len(), snapshot.len() + 1);
        // The others move with a body moving at 0.5 along x; vehicle 0 moves at 0.5
        // relative to it and flies on this command for 4 s: it reaches 2 further, and 3
        // and 4 hear of it.
        for e in &mut snapshot[1..6] {
            e.velocity = [0.5, 0.0, 0.0];
        }
        snapshot[0].velocity = [1.0, 0.0, 0.0];
        let body = Vec3::new(0.5, 0.0, 0.0);
        let moving = neighbour_lists(&snapshot, &inter, &body, 4.0);
        assert_eq!(moving.of_point(0), &[1, 2, 3, 4]);
        assert_eq!(moving.of_point(4), &[0, 2, 3, 5, 6]);
    }
}
