//! The body command between its shapes: the planner's [`Command`] of a tick becomes a
//! [`BodyRecord`] (what the coordinator checkpoints, to publish it again after a restart),
//! which fills the zero-copy payload [`BodyCommand`] the agents read. The agents turn that
//! payload into their guidance with [`BodyCommand::leader_positions`] and
//! [`BodyCommand::potentials`] (`vbap_ipc::msg`), each reading only its own neighbour list
//! ([`crate::near`]), which the payload carries beside the snapshot.

use vbap_ipc::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use vbap_ipc::msg::{
    from_potential, from_vec3, to_potential, to_vec3, Header, MAX_LEADERS, MAX_NEAR_ENTRIES,
    MAX_VEHICLES,
};
use vbap_math::neighbourhood::Neighbourhoods;
use vbap_math::schedule::MAX_PLAN;

use crate::near::neighbour_lists;
use crate::planner::Command;

/// The content of one body command (kept in the checkpoint for a re-send).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyRecord {
    /// Tick k of the command (for the step from k to k + 1).
    pub tick: u64,
    /// Mission time k·dt, s.
    pub t: f64,
    /// Sequence number: k + 1, so a resumed coordinator re-sends a tick's command under the
    /// same number, which agents that already have it ignore.
    pub seq: u64,
    /// True when the body holds position.
    pub holding: bool,
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
    /// Damping gain of (II.1), 1/s.
    pub damping: f64,
    /// Velocity of the body centre dr/ds·ṡ, length unit/s.
    pub velocity: [f64; 3],
    /// Virtual leader positions b_l(s), length unit.
    pub leaders: Vec<[f64; 3]>,
    /// Every vehicle's last known state, ordered by id.
    pub snapshot: Vec<SnapshotEntry>,
    /// Committed body path (robust law): first tick of `plan[0]` (`vbap_math::schedule`).
    #[serde(default)]
    pub plan_start: u64,
    /// Ticks per segment of the committed path (0: none).
    #[serde(default)]
    pub plan_ticks: u64,
    /// Segments of the committed path (velocity x, y, z, length unit/s; dk/dt, 1/s; ṡ, 1/s).
    #[serde(default)]
    pub plan: Vec<[f64; 5]>,
    /// Each snapshot entry's neighbour list ([`crate::near`]): entry `i`'s is
    /// `near[near_start[i]..near_start[i + 1]]` (empty in a checkpoint of an earlier
    /// version: [`BodyRecord::fill`] then computes them).
    #[serde(default)]
    pub near_start: Vec<u32>,
    #[serde(default)]
    pub near: Vec<u32>,
}

impl BodyRecord {
    /// The record of `command`, the planner's decision at tick `k` (length `dt`, s), with
    /// the swarm `snapshot` published beside it.
    pub fn from_command(k: u64, dt: f64, command: &Command, snapshot: Vec<SnapshotEntry>) -> Self {
        Self {
            tick: k,
            t: k as f64 * dt,
            seq: k + 1,
            holding: command.holding,
            s: command.body.s,
            sdot: command.sdot,
            r: from_vec3(&command.body.r),
            scale: command.body.scale,
            inter: from_potential(&command.inter),
            leader: from_potential(&command.leader),
            damping: command.damping,
            velocity: from_vec3(&command.velocity),
            leaders: command.leaders.iter().map(from_vec3).collect(),
            snapshot,
            plan_start: command.schedule.as_ref().map_or(0, |s| s.start),
            plan_ticks: command.schedule.as_ref().map_or(0, |s| s.seg_ticks),
            plan: command.schedule.as_ref().map_or_else(Vec::new, |s| {
                s.segments.iter().map(|g| g.to_array()).collect()
            }),
            near_start: Vec::new(),
            near: Vec::new(),
        }
    }

    /// This record with the neighbour lists `lists` of its snapshot (the tick's, from
    /// [`crate::tick::plan_tick`]).
    pub fn with_near(self, lists: Neighbourhoods) -> Self {
        Self {
            near_start: lists.starts,
            near: lists.near,
            ..self
        }
    }

    /// Fills the payload `body` (a reused buffer: the payload is large) with this record;
    /// the publisher stamps its header's `sent_ns` again when it sends it.
    pub fn fill(&self, body: &mut BodyCommand) {
        let flags = if self.holding {
            BodyCommand::HOLDING
        } else {
            0
        };
        body.header =
            Header::new(Header::COORDINATOR, self.tick, self.t, self.seq).with_flags(flags);
        body.s = self.s;
        body.sdot = self.sdot;
        body.r = self.r;
        body.scale = self.scale;
        body.inter = self.inter;
        body.leader = self.leader;
        body.damping = self.damping;
        body.velocity = self.velocity;
        let n_l = self.leaders.len().min(MAX_LEADERS);
        body.n_leaders = n_l as u32;
        body.leaders[..n_l].copy_from_slice(&self.leaders[..n_l]);
        let n_v = self.snapshot.len().min(MAX_VEHICLES);
        body.n_vehicles = n_v as u32;
        body.snapshot[..n_v].copy_from_slice(&self.snapshot[..n_v]);
        let n_p = self.plan.len().min(MAX_PLAN);
        body.plan_start = self.plan_start;
        body.plan_ticks = self.plan_ticks;
        body.n_plan = n_p as u32;
        body.plan[..n_p].copy_from_slice(&self.plan[..n_p]);
        if self.near_start.len() == n_v + 1 {
            fill_lists(body, &self.near_start, &self.near);
        } else {
            // A checkpoint of an earlier version: the lists of the positions and ages alone
            // (the command horizon is the fleet's, not the record's).
            let lists = neighbour_lists(
                &self.snapshot[..n_v],
                &to_potential(&self.inter),
                &to_vec3(&self.velocity),
                0.0,
            );
            fill_lists(body, &lists.starts, &lists.near);
        }
    }
}

/// Writes the neighbour lists `starts`, `near` (of the command's snapshot entries, see
/// [`BodyRecord::near_start`]) into `body`.
fn fill_lists(body: &mut BodyCommand, starts: &[u32], near: &[u32]) {
    let n_near = near.len().min(MAX_NEAR_ENTRIES);
    body.n_near = n_near as u32;
    let starts = &starts[..starts.len().min(MAX_VEHICLES + 1)];
    for (d, &s) in body.near_start.iter_mut().zip(starts) {
        *d = s.min(n_near as u32);
    }
    for (d, &j) in body.near[..n_near].iter_mut().zip(near) {
        *d = j as u16;
    }
}

/// Makes `body` the mission's last command, of tick `k` (length `dt`, s): flag
/// [`BodyCommand::FINISHED`], no leaders, no vehicles; agents end on it.
pub fn fill_finished(body: &mut BodyCommand, k: u64, dt: f64) {
    body.header =
        Header::new(Header::COORDINATOR, k, k as f64 * dt, k + 1).with_flags(BodyCommand::FINISHED);
    body.n_leaders = 0;
    body.n_vehicles = 0;
    body.n_plan = 0;
    body.n_near = 0;
    body.near_start[0] = 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::{Planner, PlannerParams, Report};
    use vbap_ipc::msg::to_vec3;
    use vbap_math::Vec3;
    use vbap_mission::config::Mission;

    /// A command of a real planner step, through every shape to the payload and back:
    /// nothing is lost or changed on the way (the payload carries f64 exactly).
    #[test]
    fn a_command_survives_record_and_payload_exactly() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n",
            "<test>",
        )
        .unwrap();
        let ids = [0, 1, 2, 3];
        let mut planner =
            Planner::new(PlannerParams::from_mission(&m), m.start_vec(), &ids).unwrap();
        let reports: Vec<Report> = ids
            .iter()
            .map(|&id| Report {
                id,
                tick: 0,
                position: Vec3::new(id as f64, 0.5 * id as f64 * id as f64, 0.0),
                velocity: Vec3::new(0.1, 0.0, 0.0),
                measurement: 1.0 + id as f64,
            })
            .collect();
        let command = planner.step(0, &reports, &reports, &[], 0.05).unwrap();
        let snapshot = vec![SnapshotEntry {
            id: 2,
            alive: SnapshotEntry::MEMBER,
            ..SnapshotEntry::default()
        }];
        let record = BodyRecord::from_command(7, 0.05, &command, snapshot.clone());
        assert_eq!((record.tick, record.seq), (7, 8));
        assert_eq!(record.t, 7.0 * 0.05);
        let mut body = Box::new(BodyCommand::empty());
        record.fill(&mut body);
        assert!(body.is_valid());
        assert_eq!(body.header.sender, Header::COORDINATOR);
        assert_eq!(
            body.header.flags & BodyCommand::HOLDING != 0,
            command.holding
        );
        assert_eq!(body.leader_positions(), command.leaders);
        assert_eq!(body.potentials(), (command.inter, command.leader));
        assert_eq!(to_vec3(&body.velocity), command.velocity);
        assert_eq!(to_vec3(&body.r), command.body.r);
        assert_eq!(body.snapshot_entries(), &snapshot[..]);
        assert_eq!((body.n_near, body.near_of(0)), (0, &[][..]));
        fill_finished(&mut body, 9, 0.05);
        assert_eq!(body.header.flags, BodyCommand::FINISHED);
        assert!(body.leader_positions().is_empty() && body.snapshot_entries().is_empty());
    }
}
