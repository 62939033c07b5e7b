//! Membership changes of the fleet, written once for the simulator and the coordinator
//! process: a vehicle is lost (the fleet forgets it and what it sent that is still in
//! flight) or admitted back (a member again at its last true state), and the event that
//! `events.jsonl` records is made here. The formation is redesigned by the planner's next
//! step, which sees the members change ([`crate::planner::Planner::step`]). Pure: the
//! caller records the event and keeps its own books (the process forgets the vehicle's
//! queued states; the simulator removes or restarts the vehicle).

use vbap_mission::rundir::Event;

use crate::fleet::Fleet;
use crate::planner::Report;

/// How the multi-process system found a vehicle lost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    /// `supervisor` (it reaped the process), `scan` (the node is listed dead or gone),
    /// `join` (a new process of the vehicle asked to join), `silence`.
    pub by: &'static str,
    /// The process id the coordinator knew for it (0: none).
    pub pid: u32,
    /// Wall ms from the death to the verdict: exact for `supervisor`, an upper bound (from
    /// the vehicle's last message) otherwise; for `silence`, how long it was silent.
    pub ms: Option<f64>,
}

/// Why a vehicle is lost, as its `lost` event says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loss {
    /// `scheduled kill`, `process died`, `process ended`, `process gone`, `process
    /// restarted`, `silent`, `stopped` (the last two are no deaths: the process lives on).
    pub cause: &'static str,
    /// How it was found (None: a scheduled kill, which the coordinator does itself).
    pub found: Option<Found>,
}

impl Loss {
    /// A kill of the mission's fault schedule.
    pub fn scheduled_kill() -> Self {
        Self {
            cause: "scheduled kill",
            found: None,
        }
    }

    /// A death (or silence) the multi-process system found `by` some means.
    pub fn found(cause: &'static str, by: &'static str, pid: u32, ms: Option<f64>) -> Self {
        Self {
            cause,
            found: Some(Found { by, pid, ms }),
        }
    }

    /// The detection latency this loss adds to `summary.json` (`detection_latency_ms`),
    /// wall ms: none for a scheduled kill, and none for silence or a stop, which are no
    /// deaths.
    pub fn detection_ms(&self) -> Option<f64> {
        if !self.is_death() {
            return None;
        }
        self.found.and_then(|f| f.ms)
    }

    /// False for a process that lives on (`silent`, `stopped`).
    pub fn is_death(&self) -> bool {
        !matches!(self.cause, "silent" | "stopped")
    }

    /// The `detail` of the `lost` event: `cause`, and when found, `by`, `pid` and
    /// `detection_ms` (`silent_ms` for silence, `stopped_ms`, since the stop, for a stop).
    pub fn detail(&self) -> serde_json::Value {
        let Some(f) = self.found else {
            return serde_json::json!({ "cause": self.cause });
        };
        let mut detail = serde_json::json!({ "cause": self.cause, "by": f.by, "pid": f.pid });
        if let Some(ms) = f.ms {
            let key = match self.cause {
                "silent" => "silent_ms",
                "stopped" => "stopped_ms",
                _ => "detection_ms",
            };
            detail[key] = serde_json::json!(ms);
        }
        detail
    }
}

/// Vehicle `v` is lost at tick `k` (length `dt`, s): the fleet forgets it. Returns the
/// `lost` event to record and the ticks of its reports the link still held, now dropped
/// ([`Fleet::lose`]); None when it was not alive (nothing changes).
pub fn lose(fleet: &mut Fleet, k: u64, dt: f64, v: u32, loss: &Loss) -> Option<(Event, Vec<u64>)> {
    let dropped = fleet.lose(v)?;
    let event = Event {
        t: k as f64 * dt,
        k,
        kind: "lost".into(),
        vehicle: Some(v),
        detail: loss.detail(),
    };
    Some((event, dropped))
}

/// Lost vehicle `v` is admitted back at tick `k` (length `dt`, s): a member from this tick
/// on, at its last true state. Returns that state (its agent resumes from it) and the
/// `rejoin` event to record; None when `v` is not lost or was never heard of.
pub fn rejoin(fleet: &mut Fleet, k: u64, dt: f64, v: u32) -> Option<(Report, Event)> {
    let restore = fleet.admit(v)?;
    let event = Event {
        t: k as f64 * dt,
        k,
        kind: "rejoin".into(),
        vehicle: Some(v),
        detail: serde_json::Value::Null,
    };
    Some((restore, event))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::{Planner, PlannerParams};
    use vbap_math::Vec3;
    use vbap_mission::config::Mission;

    const DT: f64 = 0.05;

    fn mission(links: &str) -> Mission {
        Mission::from_toml_str(
            &format!(
                "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n{links}"
            ),
            "<test>",
        )
        .unwrap()
    }

    fn report(id: u32, k: u64) -> Report {
        Report {
            id,
            tick: k,
            position: Vec3::new(k as f64 + id as f64, 2.0 * id as f64, 0.0),
            velocity: Vec3::new(0.5, 0.0, 0.0),
            measurement: id as f64,
        }
    }

    /// Tick `k` of the fleet with every alive vehicle reporting: (members, fresh) ids.
    fn tick(fleet: &mut Fleet, k: u64) -> (Vec<u32>, Vec<u32>) {
        tick_with_body(fleet, k, Vec3::zeros())
    }

    /// [`tick`] with the virtual body's centre at `r`.
    fn tick_with_body(fleet: &mut Fleet, k: u64, r: Vec3) -> (Vec<u32>, Vec<u32>) {
        let truth: Vec<Report> = fleet.alive().map(|id| report(id, k)).collect();
        fleet.receive(k, DT, &truth);
        fleet.track_body(k, r);
        let (members, fresh) = fleet.deliver(k as f64 * DT, DT);
        (
            members.iter().map(|r| r.id).collect(),
            fresh.iter().map(|r| r.id).collect(),
        )
    }

    /// The fleet of vehicles 0–3 of `m` after `ticks` ticks of every one reporting.
    fn ticked(m: &Mission, ticks: u64) -> Fleet {
        let mut fleet = Fleet::new(m, &[0, 1, 2, 3]);
        for k in 0..ticks {
            tick(&mut fleet, k);
            fleet.end_tick();
        }
        fleet
    }

    /// The fleet of every vehicle of `m`, its planner, and where each vehicle's slot of the
    /// initial formation is.
    fn fleet_and_planner(m: &Mission) -> (Fleet, Planner, Vec<Vec3>) {
        let ids: Vec<u32> = (0..m.vehicles.count as u32).collect();
        let planner = Planner::new(PlannerParams::from_mission(m), m.start_vec(), &ids).unwrap();
        let home = planner
            .design()
            .slots
            .iter()
            .map(|p| m.start_vec() + p)
            .collect();
        (Fleet::new(m, &ids), planner, home)
    }

    /// Tick `k` of `fleet` and `planner` with every live vehicle not admitted at this tick
    /// at rest at `at(id)` (the true reports, as the simulator takes them): the reports and
    /// the planner's command. The fleet's tick is not ended (`Fleet::end_tick`).
    fn at_rest(
        fleet: &mut Fleet,
        planner: &mut Planner,
        k: u64,
        at: impl Fn(u32) -> Vec3,
    ) -> (Vec<Report>, crate::planner::Command) {
        let admitted: Vec<u32> = fleet.admitted().iter().map(|r| r.id).collect();
        let truth: Vec<Report> = fleet
            .alive()
            .filter(|id| !admitted.contains(id))
            .map(|id| Report {
                id,
                tick: k,
                position: at(id),
                velocity: Vec3::zeros(),
                measurement: 1.0,
            })
            .collect();
        fleet.receive(k, DT, &truth);
        fleet.track_body(k, planner.body().r);
        let (members, fresh) = fleet.deliver(k as f64 * DT, DT);
        planner.see_hulls(&fleet.hulls());
        let command = planner.step(k, &members, &fresh, &admitted, DT).unwrap();
        (truth, command)
    }

    #[test]
    fn loss_details_say_how_the_vehicle_was_found() {
        let kill = Loss::scheduled_kill();
        assert_eq!(
            kill.detail(),
            serde_json::json!({ "cause": "scheduled kill" })
        );
        assert_eq!(kill.detection_ms(), None);
        let scan = Loss::found("process died", "scan", 42, Some(12.5));
        assert_eq!(
            scan.detail(),
            serde_json::json!({ "cause": "process died", "by": "scan", "pid": 42,
                "detection_ms": 12.5 })
        );
        assert_eq!(scan.detection_ms(), Some(12.5));
        // Silence is no death: how long it lasted, not a detection latency.
        let quiet = Loss::found("silent", "silence", 7, Some(10_000.0));
        assert_eq!(quiet.detail()["silent_ms"], 10_000.0);
        assert!(quiet.detail().get("detection_ms").is_none());
        assert_eq!(quiet.detection_ms(), None);
        let unknown = Loss::found("process restarted", "join", 3, None);
        assert_eq!(
            unknown.detail(),
            serde_json::json!({ "cause": "process restarted", "by": "join", "pid": 3 })
        );
    }

    /// Lose, then admit back: the fleet's books at each step, and the events made.
    #[test]
    fn lose_and_rejoin_keep_the_fleet_books() {
        let m = mission("");
        let mut fleet = Fleet::new(&m, &[0, 1, 2, 3]);
        assert_eq!(tick(&mut fleet, 0), (vec![0, 1, 2, 3], vec![0, 1, 2, 3]));
        fleet.end_tick();
        let (lost, in_flight) = lose(&mut fleet, 1, DT, 2, &Loss::scheduled_kill()).unwrap();
        assert!(in_flight.is_empty(), "ideal links hold nothing");
        assert_eq!(
            (lost.kind.as_str(), lost.k, lost.vehicle),
            ("lost", 1, Some(2))
        );
        assert_eq!(lost.t, 1.0 * DT);
        assert!(!fleet.is_alive(2) && fleet.is_lost(2));
        assert_eq!(fleet.newest_report(2), None);
        // Losing it again changes nothing; a vehicle never lost cannot rejoin.
        assert!(lose(&mut fleet, 1, DT, 2, &Loss::scheduled_kill()).is_none());
        assert!(rejoin(&mut fleet, 1, DT, 1).is_none());
        assert_eq!(tick(&mut fleet, 1), (vec![0, 1, 3], vec![0, 1, 3]));
        fleet.end_tick();

        let (restore, event) = rejoin(&mut fleet, 5, DT, 2).unwrap();
        assert_eq!(restore, report(2, 0), "its last true state");
        assert_eq!((event.kind.as_str(), event.vehicle), ("rejoin", Some(2)));
        assert!(event.detail.is_null());
        assert!(fleet.is_alive(2) && !fleet.is_lost(2));
        assert_eq!(
            fleet.admitted().iter().map(|r| r.id).collect::<Vec<_>>(),
            [2]
        );
        // Admitted at this tick: a member at its restore state, not yet reporting.
        let truth: Vec<Report> = [0, 1, 3].iter().map(|&id| report(id, 5)).collect();
        fleet.receive(5, DT, &truth);
        fleet.track_body(5, Vec3::zeros());
        let (members, _) = fleet.deliver(5.0 * DT, DT);
        let back = members.iter().find(|r| r.id == 2).unwrap();
        assert_eq!((back.tick, back.position), (5, restore.position));
        fleet.end_tick();
        assert!(fleet.admitted().is_empty());
        assert_eq!(tick(&mut fleet, 6).0, vec![0, 1, 2, 3]);
    }

    /// A lost vehicle is in the snapshot where it was last heard of (its hull), not where
    /// its truth was: over delayed links the two differ. Admitted back, it is a member.
    #[test]
    fn a_lost_vehicle_s_hull_is_where_it_was_last_heard_of() {
        use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
        // The body moves 0.2 along x per tick: the hull is the last report moved with it
        // from the report's tick to the loss's (where a member out of contact is seen).
        let body = |k: u64| Vec3::new(0.2 * k as f64, 0.0, 0.0);
        let mut fleet = Fleet::new(&mission("[links]\ndelay = 0.1"), &[0, 1, 2, 3]);
        for k in 0..6 {
            tick_with_body(&mut fleet, k, body(k));
            fleet.end_tick();
        }
        let heard = *fleet.newest_report(2).unwrap();
        assert!(heard.tick < 5, "the links hold the newest reports");
        lose(&mut fleet, 6, DT, 2, &Loss::scheduled_kill()).unwrap();
        let (members, _) = fleet.deliver(6.0 * DT, DT);
        let snapshot = fleet.snapshot(&members, &[]);
        let hull = snapshot.iter().find(|e| e.id == 2).unwrap();
        assert_eq!(hull.alive, SnapshotEntry::LOST);
        // Moved with the body up to the last tick tracked before the loss (5).
        let reckoned = heard.position + body(5) - body(heard.tick);
        assert_eq!(vbap_ipc::msg::to_vec3(&hull.position), reckoned);
        assert_eq!(fleet.hulls(), vec![reckoned]);
        assert_ne!(reckoned, report(2, 5).position, "not the truth");
        fleet.end_tick();
        let (restore, _) = rejoin(&mut fleet, 7, DT, 2).unwrap();
        assert_eq!(restore, report(2, 5), "restarted at its last true state");
        let (members, _) = fleet.deliver(7.0 * DT, DT);
        let snapshot = fleet.snapshot(&members, &[]);
        assert!(snapshot
            .iter()
            .filter(|e| e.id == 2)
            .all(|e| e.alive != SnapshotEntry::LOST));
    }

    /// Reports a lost vehicle sent that the links still hold are dropped with it.
    #[test]
    fn a_lost_vehicle_s_reports_in_flight_are_dropped() {
        let mut fleet = ticked(&mission("[links]\ndelay = 0.5\n"), 3);
        let held = |f: &Fleet, v: u32| f.held_reports().0.iter().filter(|e| e.2.id == v).count();
        let before = held(&fleet, 1);
        assert!(before > 0, "a 0.5 s delay holds reports");
        let dropped_before = fleet.counts.dropped_injected;
        let (_, in_flight) = lose(
            &mut fleet,
            3,
            DT,
            1,
            &Loss::found("process died", "scan", 9, None),
        )
        .unwrap();
        assert_eq!(held(&fleet, 1), 0);
        assert_eq!(in_flight.len(), before, "the reports held are returned");
        assert_eq!(
            fleet.counts.dropped_injected,
            dropped_before + before as u64,
            "and counted as dropped with the vehicle"
        );
        for k in 3..30 {
            let (members, fresh) = tick(&mut fleet, k);
            assert!(!members.contains(&1) && !fresh.contains(&1));
            fleet.end_tick();
        }
    }

    /// Two losses leave two holes; a vehicle that comes back nearer the other lost
    /// vehicle's hole than its own is given its own: the other's hull is still in its hole
    /// (where it was last heard of), and its process, restarted, comes back there.
    #[test]
    fn a_returning_vehicle_is_not_given_a_hole_with_another_lost_vehicle_s_hull() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 6\n[control]\nlaw = \"robust\"\n",
            "<test>",
        )
        .unwrap();
        let (mut fleet, mut planner, home) = fleet_and_planner(&m);
        let (slot1, slot2) = (home[1], home[2]);
        // Vehicle 1 was last heard of between the two slots, nearer vehicle 2's.
        let drifted = slot2 + 0.4 * (slot1 - slot2);
        let mut step = |fleet: &mut Fleet, k: u64| {
            let at = |id: u32| if id == 1 { drifted } else { home[id as usize] };
            let (_, c) = at_rest(fleet, &mut planner, k, at);
            fleet.end_tick();
            c
        };
        for k in 0..3 {
            step(&mut fleet, k);
        }
        lose(&mut fleet, 3, DT, 1, &Loss::scheduled_kill()).unwrap();
        step(&mut fleet, 3);
        lose(&mut fleet, 4, DT, 2, &Loss::scheduled_kill()).unwrap();
        step(&mut fleet, 4);
        assert_eq!(fleet.hulls(), vec![drifted, slot2]);
        let (restore, _) = rejoin(&mut fleet, 5, DT, 1).unwrap();
        assert_eq!(restore.position, drifted);
        let c = step(&mut fleet, 5);
        let target = c.rejoining.iter().find(|(id, _)| *id == 1).unwrap().1;
        assert!(
            (target - slot1).norm() < 0.1 * (slot1 - slot2).norm(),
            "its own hole {slot1:?}, not {slot2:?}: {target:?}"
        );
    }

    /// A process restarted onto a member is a near collision at the tick of its
    /// admission, before it has a true report of its own: the next tick their repulsion
    /// has already thrown them apart.
    #[test]
    fn a_restart_onto_a_member_is_a_near_collision_at_its_admission() {
        let m = mission("[control]\nlaw = \"robust\"");
        let (mut fleet, mut planner, home) = fleet_and_planner(&m);
        let mut stats = crate::truth::TruthStats::new(&m);
        // Vehicle 2 dies next to vehicle 1's slot, 0.05 spacing from it.
        let spacing = planner.design().neighbour_spacing();
        let on_one = home[1] + Vec3::new(0.05 * spacing, 0.0, 0.0);
        let mut step = |fleet: &mut Fleet, k: u64| {
            let at = |id: u32| if id == 2 { on_one } else { home[id as usize] };
            let (truth, c) = at_rest(fleet, &mut planner, k, at);
            let tick =
                crate::truth::tick(&mut stats, &m, k, &truth, &c, planner.design(), fleet, None);
            fleet.end_tick();
            tick
        };
        for k in 0..3 {
            step(&mut fleet, k);
        }
        lose(&mut fleet, 3, DT, 2, &Loss::scheduled_kill()).unwrap();
        let before = step(&mut fleet, 3);
        assert!(before.row.min_pair_ratio.unwrap() > 0.5);
        rejoin(&mut fleet, 4, DT, 2).unwrap();
        let back = step(&mut fleet, 4);
        let ratio = back.row.min_pair_ratio.unwrap();
        // 0.05 of the design's spacing, measured against the body's (scaled) spacing.
        assert!(ratio > 0.04 && ratio < 0.06, "{ratio}");
        assert!(back.events.iter().any(
            |e| e.kind == "near_collision" && e.detail["vehicles"] == serde_json::json!([1, 2])
        ));
    }

    /// Losing a member redesigns the formation for the vehicles left at the planner's next
    /// step; admitting it back redesigns it again, with the vehicle rejoining.
    #[test]
    fn membership_changes_redesign_the_formation() {
        let m = mission("");
        let (mut fleet, mut planner, _) = fleet_and_planner(&m);
        let mut step = |fleet: &mut Fleet, k: u64| {
            let truth: Vec<Report> = fleet.alive().map(|id| report(id, k)).collect();
            fleet.receive(k, DT, &truth);
            fleet.track_body(k, planner.body().r);
            let joined: Vec<u32> = fleet.admitted().iter().map(|r| r.id).collect();
            let (members, fresh) = fleet.deliver(k as f64 * DT, DT);
            let c = planner.step(k, &members, &fresh, &joined, DT).unwrap();
            fleet.end_tick();
            (c, planner.design().slots.len(), planner.reconfigurations())
        };
        let (c, slots, n) = step(&mut fleet, 0);
        assert!(!c.reconfigured);
        assert_eq!((slots, n), (4, 0));
        lose(&mut fleet, 1, DT, 3, &Loss::scheduled_kill()).unwrap();
        let (c, slots, n) = step(&mut fleet, 1);
        assert!(c.reconfigured);
        assert_eq!((c.members.clone(), slots, n), (vec![0, 1, 2], 3, 1));
        rejoin(&mut fleet, 2, DT, 3).unwrap();
        let (c, slots, n) = step(&mut fleet, 2);
        assert!(c.reconfigured);
        assert_eq!((c.members, slots, n), (vec![0, 1, 2, 3], 4, 2));
        assert!(
            c.rejoining.iter().any(|(id, _)| *id == 3),
            "it flies back to a slot"
        );
    }
}
