//! Each vehicle's part of a tick of truth: its slot error and nearest neighbour from its
//! true state, its contact, its row of `formation.csv`; and the fleet's tally of them.

use std::collections::BTreeSet;

use vbap_math::fit::{fit_slots, nearest_neighbours, spacing, IN_FORMATION};
use vbap_math::formation::FormationDesign;
use vbap_mission::rundir::{Event, FormationRow};

use super::silence::{contact_event, follow_silence};
use super::{event, TruthStats};
use crate::fleet::Fleet;
use crate::planner::{Command, Report};

/// What the tick is judged from.
pub(super) struct Scene<'a> {
    /// Tick, its mission time (s) and the tick length (s).
    pub k: u64,
    pub t: f64,
    pub dt: f64,
    /// The true reports, ordered by id.
    pub truth: &'a [Report],
    /// The formation's members this tick.
    pub members: &'a BTreeSet<u32>,
    pub command: &'a Command,
    pub design: &'a FormationDesign,
    pub fleet: &'a Fleet,
    pub dim: usize,
}

/// The fleet's figures of one tick.
#[derive(Debug, Default)]
pub(super) struct Tally {
    pub n_alive: usize,
    pub n_in: usize,
    /// The live vehicles out of formation, by id.
    pub out: Vec<u32>,
    /// (slot error ÷ spacing, vehicle) of the worst slot error.
    pub max_slot: Option<(f64, u32)>,
    /// (distance ÷ spacing, a, b) of the closest pair (a < b).
    pub min_pair: Option<(f64, u32, u32)>,
    /// True when some member's newest state is older than the silence threshold (or
    /// there is none).
    pub stale_member: bool,
}

impl Tally {
    /// Keeps the pair of vehicles `a` and `b` at distance `r` (÷ spacing) when it is the
    /// closest so far.
    fn offer_pair(&mut self, r: f64, a: u32, b: u32) {
        if self.min_pair.is_none_or(|(m, _, _)| r < m) {
            self.min_pair = Some((r, a.min(b), a.max(b)));
        }
    }
}

/// One vehicle's true figures: slot error and nearest neighbour (index into the true
/// reports, distance), both ÷ the design spacing.
struct Fit {
    slot_error: Option<f64>,
    nearest: Option<(usize, f64)>,
}

/// Every vehicle's row of `formation.csv` for the tick of `scene` and the tally of the
/// fleet; each vehicle's running state in `stats` brought up to date, its contact events
/// pushed onto `events`. In formation: slot error ≤ [`IN_FORMATION`] spacing.
pub(super) fn vehicles(
    stats: &mut TruthStats,
    scene: &Scene,
    events: &mut Vec<Event>,
) -> (Vec<FormationRow<'static>>, Tally) {
    // Slots and nearest pairs of every vehicle with a true state.
    let d = spacing(scene.design, &scene.command.body);
    let positions: Vec<_> = scene.truth.iter().map(|q| q.position).collect();
    let fit = fit_slots(&positions, scene.design, &scene.command.body, scene.dim);
    let near = nearest_neighbours(&positions);
    let ratio = |x: f64| if d > 0.0 { x / d } else { f64::INFINITY };

    let n = stats.vehicles.len();
    let mut rows = Vec::with_capacity(n);
    let mut tally = Tally::default();
    for id in 0..n as u32 {
        let at = scene.truth.iter().position(|q| q.id == id);
        let alive = scene.fleet.is_alive(id);
        let own = Fit {
            slot_error: at.filter(|_| alive).map(|i| ratio(fit.errors[i])),
            nearest: at
                .filter(|_| alive)
                .and_then(|i| near[i].map(|(j, dist)| (j, ratio(dist)))),
        };
        rows.push(vehicle(stats, scene, id, own, &mut tally, events));
    }
    restarted_pairs(scene, &positions, ratio, &mut tally);
    (rows, tally)
}

/// Counts into `tally`'s closest pair every vehicle admitted back at this tick (a process
/// restarted where its vehicle was, `Fleet::admitted`, at its restore state: it has no true
/// report of this tick yet) against every vehicle of the tick's truth (`positions`), its
/// distance `ratio`-ed to the design spacing. A restart onto a member is a collision at
/// this very tick; the next tick, their repulsion has already thrown them apart (stress
/// seed 13, m0779: 13 L apart one tick later, at 134 L/s, and no near collision counted).
fn restarted_pairs(
    scene: &Scene,
    positions: &[vbap_math::Vec3],
    ratio: impl Fn(f64) -> f64,
    tally: &mut Tally,
) {
    for back in scene.fleet.admitted() {
        for (q, p) in scene.truth.iter().zip(positions) {
            if q.id == back.id {
                continue;
            }
            tally.offer_pair(ratio((back.position - p).norm()), back.id, q.id);
        }
    }
}

/// Vehicle `id`'s row, with its figures `own`, counted into `tally`.
fn vehicle(
    stats: &mut TruthStats,
    scene: &Scene,
    id: u32,
    own: Fit,
    tally: &mut Tally,
    events: &mut Vec<Event>,
) -> FormationRow<'static> {
    let (k, t) = (scene.k, scene.t);
    let alive = scene.fleet.is_alive(id);
    let contact = contact(scene, id, alive);
    let info_age = if alive {
        scene
            .fleet
            .newest_report(id)
            .map(|r| t - r.tick as f64 * scene.dt)
    } else {
        None
    };
    let slot_error = own.slot_error;
    let in_formation = slot_error.is_some_and(|e| e <= IN_FORMATION);
    if alive {
        tally.n_alive += 1;
        if in_formation {
            tally.n_in += 1;
        } else {
            tally.out.push(id);
        }
    }
    if let Some(e) = slot_error {
        if tally.max_slot.is_none_or(|(m, _)| e > m) {
            tally.max_slot = Some((e, id));
        }
    }
    if let Some((j, r)) = own.nearest {
        let other = scene.truth[j].id;
        if id < other {
            tally.offer_pair(r, id, other);
        }
    }
    let silence_after = stats.silence_after;
    let vt = &mut stats.vehicles[id as usize];
    if let Some(a) = info_age {
        vt.max_age = Some(vt.max_age.map_or(a, |m: f64| m.max(a)));
    }
    // Contact events: surfacing schedule, link_down faults, long silences.
    let was = std::mem::replace(&mut vt.contact, contact.to_string());
    if k > 0 && was != contact {
        if let Some((kind, detail)) = contact_event(&was, contact) {
            events.push(event(t, k, kind, Some(id), detail));
        }
    }
    let talks = alive
        && matches!(contact, "contact" | "surfaced")
        && scene.fleet.model().contact(id, t).can_talk();
    if let Some((kind, detail)) = follow_silence(vt, talks, info_age, t, silence_after) {
        events.push(event(t, k, kind, Some(id), detail));
    }
    if scene.members.contains(&id) && info_age.is_none_or(|a| a > silence_after) {
        tally.stale_member = true;
    }
    // The end-of-run judgment keeps a live vehicle's newest true state: in a paced run a
    // state that missed the last tick's deadline is news not yet in, not a vehicle out of
    // formation (this tick's row still says it has no state).
    if slot_error.is_some() || !alive {
        vt.slot_error = slot_error;
        vt.in_formation = in_formation;
    }
    vt.alive = alive;
    FormationRow {
        t,
        k,
        id,
        contact,
        info_age_s: info_age,
        slot_error,
        nearest_ratio: own.nearest.map(|(_, r)| r),
        in_formation,
    }
}

/// Vehicle `id`'s contact at the tick: `dead`, `rejoining` (admitted back and not yet a
/// member, or a member still flying home to its slot: `vbap_math::rejoin`), or its
/// contact by the link schedule.
fn contact(scene: &Scene, id: u32, alive: bool) -> &'static str {
    if !alive {
        "dead"
    } else if !scene.members.contains(&id) || scene.command.rejoining.iter().any(|(v, _)| *v == id)
    {
        "rejoining"
    } else {
        scene.fleet.model().contact(id, scene.t).as_str()
    }
}
