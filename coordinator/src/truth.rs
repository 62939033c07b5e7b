//! The formation judged from the vehicles' TRUE states, every tick (`formation.csv`,
//! `truth.csv`, the events a user needs to see, and the `formation` object, `verdict` and
//! `reasons` of `summary.json`). The recorder is omniscient (it sees the true states the
//! planner only hears about through the links); this is where that is put to use. Called
//! from [`crate::tick::plan_tick`], so `vbap sim` and `vbap run` write the same bytes; its
//! running state ([`TruthStats`]) is checkpointed with the recorder's.
//!
//! Thresholds (documented in README.md):
//! - in formation: slot error ≤ [`IN_FORMATION`] × spacing;
//! - near collision: a pair closer than [`NEAR_COLLISION`] × spacing;
//! - stall: ṡ below [`STALL_FRACTION`] × v0 for longer than [`TruthStats::stall_after`]
//!   (the time the body needs to cross one design spacing at v0, at least
//!   [`DEBOUNCE_TICKS`] ticks); it ends when ṡ is back above twice that fraction;
//! - silence: a vehicle in contact by the schedule whose newest delivered state is older
//!   than `delay + jitter + SILENCE_TICKS · dt` ([`TruthStats::silence_after`]);
//! - formation broken / restored events are debounced: the new state must hold for
//!   [`DEBOUNCE_TICKS`] ticks; a near-collision event re-arms once the closest pair is back
//!   beyond twice the threshold.

use std::collections::BTreeSet;

use vbap_math::fit::{fit_slots, nearest_neighbours, potential_energy_sparse, spacing};
pub use vbap_math::fit::{IN_FORMATION, NEAR_COLLISION};
use vbap_math::formation::FormationDesign;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{Event, FormationRow, FormationSummary, TruthRow};

use crate::fleet::Fleet;
use crate::planner::{Command, Report};

/// ṡ below this fraction of v0 counts as slow (a stall once it lasts).
pub const STALL_FRACTION: f64 = 0.1;
/// Ticks a new formation state (broken / restored) must hold before it is an event; also
/// the least stall duration.
pub const DEBOUNCE_TICKS: u64 = 20;
/// Ticks beyond the link's delay + jitter without news before a vehicle in contact counts
/// as silent.
pub const SILENCE_TICKS: f64 = 20.0;

/// Per-vehicle running state.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VehicleTruth {
    /// Contact state written last tick ("" before the first tick).
    pub contact: String,
    /// Mission time since which the vehicle can talk by the schedule.
    pub talk_since: Option<f64>,
    /// True while a silence is reported (contact_lost without a link_down).
    pub silent: bool,
    /// Largest info age seen, s.
    pub max_age: Option<f64>,
    /// Slot error ÷ spacing at the last tick (none when dead).
    pub slot_error: Option<f64>,
    /// Alive at the last tick.
    pub alive: bool,
    /// In formation at the last tick.
    pub in_formation: bool,
}

/// The running truth figures (checkpointed).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TruthStats {
    pub vehicles: Vec<VehicleTruth>,
    pub max_v_true: f64,
    pub max_v_seen: f64,
    pub ticks: u64,
    pub ticks_v_above: u64,
    /// (ratio, t, a, b) of the closest pair.
    pub min_pair: Option<(f64, f64, u32, u32)>,
    pub near_collision_ticks: u64,
    /// False while a near collision is reported (re-armed beyond twice the threshold).
    pub near_reported: bool,
    /// (ratio, vehicle, t) of the worst slot error.
    pub worst_slot: Option<(f64, u32, f64)>,
    /// The formation state last reported (true = broken), and the vehicles then out.
    pub broken: bool,
    /// Tick and time since which the current state differs from the reported one.
    pub pending: Option<(u64, f64)>,
    /// Since when ṡ has been slow (t), and whether a stall is reported, and why.
    pub slow_since: Option<f64>,
    pub stalled: bool,
    pub stall_why: String,
    pub stalled_s: f64,
    /// Distance of the body from the optimum at the first tick.
    pub start_distance: Option<f64>,
    /// Thresholds fixed at the start, s.
    pub stall_after: f64,
    pub silence_after: f64,
}

impl TruthStats {
    /// The state at the start of `mission`.
    pub fn new(mission: &Mission) -> Self {
        let dt = mission.mission.dt;
        let d0 = vbap_math::formation::design_regular(
            mission.vehicles.count,
            mission.mission.dim,
            mission.formation.radius,
            mission.formation.alpha,
            mission.formation.alpha,
        )
        .map(|d| d.neighbour_spacing())
        .unwrap_or(0.0);
        let v0 = mission.body.v0;
        let cross = if v0 > 0.0 { d0 / v0 } else { 0.0 };
        Self {
            vehicles: vec![VehicleTruth::default(); mission.vehicles.count],
            near_reported: false,
            stall_after: cross.max(DEBOUNCE_TICKS as f64 * dt),
            silence_after: mission.links.delay + mission.links.jitter + SILENCE_TICKS * dt,
            ..Self::default()
        }
    }
}

/// What one tick of truth produced for the files.
pub struct TruthTick {
    pub rows: Vec<FormationRow<'static>>,
    pub row: TruthRow,
    pub events: Vec<Event>,
}

fn event(t: f64, k: u64, kind: &str, vehicle: Option<u32>, detail: serde_json::Value) -> Event {
    Event {
        t,
        k,
        kind: kind.into(),
        vehicle,
        detail,
    }
}

/// One tick of truth: `truth` the true reports (ordered by id), `command` the planner's
/// decision with `design` its formation design, `fleet` the coordinator's view after the
/// tick's deliveries.
#[allow(clippy::too_many_arguments)]
pub fn tick(
    stats: &mut TruthStats,
    mission: &Mission,
    k: u64,
    truth: &[Report],
    command: &Command,
    design: &FormationDesign,
    fleet: &Fleet,
    distance: Option<f64>,
) -> TruthTick {
    let dt = mission.mission.dt;
    let t = k as f64 * dt;
    let v_u = mission.body.v_u;
    let v0 = mission.body.v0;
    let dim = mission.mission.dim;
    let mut events = Vec::new();
    if k == 0 || stats.start_distance.is_none() {
        stats.start_distance = stats.start_distance.or(distance);
    }

    // V of (II.2) from the true states of the formation's members.
    let members: BTreeSet<u32> = command.members.iter().copied().collect();
    let (pos, vel): (Vec<_>, Vec<_>) = truth
        .iter()
        .filter(|q| members.contains(&q.id))
        .map(|q| (q.position, q.velocity))
        .unzip();
    // V = max(0, ½ Σ|v|² + potential − E_n), as `lyapunov_terms` (the sparse sum of the
    // potential costs O(n) per vehicle near the formation instead of O(n²)).
    let kinetic: f64 = vel.iter().map(|v| v.norm_squared()).sum();
    let potential = potential_energy_sparse(
        &pos,
        &command.body.leader_positions(design),
        &command.body.scaled_inter(design),
        &command.body.scaled_leader(design),
    );
    let v_true = (0.5 * kinetic + potential - design.equilibrium_energy(pos.len())).max(0.0) / v_u;
    let v_seen = command.terms.v / v_u;

    // Slots and nearest pairs of every vehicle with a true state.
    let d = spacing(design, &command.body);
    let positions: Vec<_> = truth.iter().map(|q| q.position).collect();
    let fit = fit_slots(&positions, design, &command.body, dim);
    let near = nearest_neighbours(&positions);
    let ratio = |x: f64| if d > 0.0 { x / d } else { f64::INFINITY };

    let n = stats.vehicles.len();
    let mut rows = Vec::with_capacity(n);
    let mut n_alive = 0;
    let mut n_in = 0;
    let mut out: Vec<u32> = Vec::new();
    let mut max_slot: Option<(f64, u32)> = None;
    let mut min_pair: Option<(f64, u32, u32)> = None;
    let mut stale_member = false;
    for id in 0..n as u32 {
        let at = truth.iter().position(|q| q.id == id);
        let alive = fleet.is_alive(id);
        let contact = if !alive {
            "dead"
        } else if !members.contains(&id) || command.rejoining.iter().any(|(v, _)| *v == id) {
            // Admitted back and not yet a member, or a member still flying home to its
            // slot (`vbap_math::rejoin`).
            "rejoining"
        } else {
            fleet.model().contact(id, t).as_str()
        };
        let info_age = if alive {
            fleet.newest_report(id).map(|r| t - r.tick as f64 * dt)
        } else {
            None
        };
        let slot_error = at.filter(|_| alive).map(|i| ratio(fit.errors[i]));
        let nearest = at
            .filter(|_| alive)
            .and_then(|i| near[i].map(|(j, dist)| (j, ratio(dist))));
        let in_formation = slot_error.is_some_and(|e| e <= IN_FORMATION);
        if alive {
            n_alive += 1;
            if in_formation {
                n_in += 1;
            } else {
                out.push(id);
            }
        }
        if let Some(e) = slot_error {
            if max_slot.is_none_or(|(m, _)| e > m) {
                max_slot = Some((e, id));
            }
        }
        if let Some((j, r)) = nearest {
            let other = truth[j].id;
            if id < other && min_pair.is_none_or(|(m, _, _)| r < m) {
                min_pair = Some((r, id, other));
            }
        }
        let vt = &mut stats.vehicles[id as usize];
        if let Some(a) = info_age {
            vt.max_age = Some(vt.max_age.map_or(a, |m: f64| m.max(a)));
        }
        // Contact events: surfacing schedule, link_down faults, long silences.
        let was = std::mem::replace(&mut vt.contact, contact.to_string());
        if k > 0 && was != contact {
            match (was.as_str(), contact) {
                ("submerged", "surfaced") => {
                    events.push(event(t, k, "surfaced", Some(id), serde_json::Value::Null))
                }
                ("surfaced", "submerged") => {
                    events.push(event(t, k, "dived", Some(id), serde_json::Value::Null))
                }
                (_, "link_down") => events.push(event(
                    t,
                    k,
                    "contact_lost",
                    Some(id),
                    serde_json::json!({ "why": "link_down" }),
                )),
                ("link_down", "contact" | "surfaced" | "submerged") => events.push(event(
                    t,
                    k,
                    "contact_regained",
                    Some(id),
                    serde_json::json!({ "why": "link_down ended" }),
                )),
                _ => {}
            }
        }
        let talks = alive
            && matches!(contact, "contact" | "surfaced")
            && fleet.model().contact(id, t).can_talk();
        vt.talk_since = if talks {
            Some(vt.talk_since.unwrap_or(t))
        } else {
            None
        };
        let silent = talks
            && vt.talk_since.is_some_and(|s| t - s >= stats.silence_after)
            && info_age.is_some_and(|a| a > stats.silence_after);
        if silent {
            if !vt.silent {
                vt.silent = true;
                events.push(event(
                    t,
                    k,
                    "contact_lost",
                    Some(id),
                    serde_json::json!({ "why": "silence", "info_age_s": info_age }),
                ));
            }
        } else if vt.silent {
            // Back in touch, or out of contact for a reason of its own (dived, link down,
            // lost), which has its own event.
            vt.silent = false;
            if talks && info_age.is_some_and(|a| a <= stats.silence_after) {
                events.push(event(
                    t,
                    k,
                    "contact_regained",
                    Some(id),
                    serde_json::json!({ "why": "reports delivered again", "info_age_s": info_age }),
                ));
            }
        }
        if members.contains(&id) && info_age.is_none_or(|a| a > stats.silence_after) {
            stale_member = true;
        }
        vt.slot_error = slot_error;
        vt.alive = alive;
        vt.in_formation = in_formation;
        rows.push(FormationRow {
            t,
            k,
            id,
            contact,
            info_age_s: info_age,
            slot_error,
            nearest_ratio: nearest.map(|(_, r)| r),
            in_formation,
        });
    }

    // Running figures.
    stats.ticks += 1;
    stats.max_v_true = stats.max_v_true.max(v_true);
    stats.max_v_seen = stats.max_v_seen.max(v_seen);
    if v_true > 1.0 {
        stats.ticks_v_above += 1;
    }
    if let Some((r, a, b)) = min_pair {
        if stats.min_pair.is_none_or(|(m, ..)| r < m) {
            stats.min_pair = Some((r, t, a, b));
        }
        if r < NEAR_COLLISION {
            stats.near_collision_ticks += 1;
            if !stats.near_reported {
                stats.near_reported = true;
                events.push(event(
                    t,
                    k,
                    "near_collision",
                    None,
                    serde_json::json!({ "vehicles": [a, b], "ratio": r }),
                ));
            }
        } else if r >= 2.0 * NEAR_COLLISION {
            stats.near_reported = false;
        }
    }
    if let Some((e, id)) = max_slot {
        if stats.worst_slot.is_none_or(|(m, ..)| e > m) {
            stats.worst_slot = Some((e, id, t));
        }
    }

    // Formation broken / restored, debounced.
    let broken = !out.is_empty();
    if broken != stats.broken {
        let (since_k, since_t) = *stats.pending.get_or_insert((k, t));
        if k + 1 - since_k >= DEBOUNCE_TICKS {
            stats.broken = broken;
            stats.pending = None;
            let worst =
                max_slot.map(|(e, id)| serde_json::json!({ "vehicle": id, "slot_error": e }));
            events.push(event(
                t,
                k,
                if broken {
                    "formation_broken"
                } else {
                    "formation_restored"
                },
                None,
                serde_json::json!({ "vehicles": out, "since": since_t, "worst": worst }),
            ));
        }
    } else {
        stats.pending = None;
    }

    // Stalls.
    let sdot_ratio = if v0 > 0.0 { command.sdot / v0 } else { 0.0 };
    if sdot_ratio < STALL_FRACTION {
        let since = *stats.slow_since.get_or_insert(t);
        if !stats.stalled && t - since >= stats.stall_after {
            stats.stalled = true;
            let why = if command.holding {
                "holding"
            } else if v_seen >= 1.0 {
                "V above V_U"
            } else if stale_member {
                "waiting for reports"
            } else if v_seen >= 0.5 {
                "V above V_U/2"
            } else {
                "slow"
            };
            stats.stall_why = why.to_string();
            stats.stalled_s += t - since;
            events.push(event(
                t,
                k,
                "stall_began",
                None,
                serde_json::json!({ "why": why, "since": since, "V_seen_over_VU": v_seen, "V_true_over_VU": v_true, "sdot_over_v0": sdot_ratio }),
            ));
        } else if stats.stalled {
            stats.stalled_s += dt;
        }
    } else if stats.stalled && sdot_ratio < 2.0 * STALL_FRACTION {
        stats.stalled_s += dt;
    } else {
        if stats.stalled {
            let since = stats.slow_since.unwrap_or(t);
            events.push(event(
                t,
                k,
                "stall_ended",
                None,
                serde_json::json!({ "why": stats.stall_why, "duration_s": t - since }),
            ));
        }
        stats.stalled = false;
        stats.slow_since = None;
    }

    TruthTick {
        rows,
        row: TruthRow {
            t,
            k,
            v_true_over_vu: v_true,
            v_seen_over_vu: v_seen,
            min_pair_ratio: min_pair.map(|(r, ..)| r),
            max_slot_error: max_slot.map(|(e, _)| e),
            n_alive,
            n_in_formation: n_in,
            sdot_over_v0: sdot_ratio,
        },
        events,
    }
}

/// The `formation` object of `summary.json`.
pub fn summary(stats: &TruthStats) -> FormationSummary {
    let alive: Vec<(u32, &VehicleTruth)> = stats
        .vehicles
        .iter()
        .enumerate()
        .filter(|(_, v)| v.alive)
        .map(|(i, v)| (i as u32, v))
        .collect();
    FormationSummary {
        max_v_true_over_vu: stats.max_v_true,
        max_v_seen_over_vu: stats.max_v_seen,
        share_ticks_v_true_above_vu: if stats.ticks > 0 {
            stats.ticks_v_above as f64 / stats.ticks as f64
        } else {
            0.0
        },
        min_pair_ratio: stats.min_pair.map(|p| p.0),
        min_pair_t: stats.min_pair.map(|p| p.1),
        min_pair_vehicles: stats.min_pair.map(|p| [p.2, p.3]),
        near_collision_ticks: stats.near_collision_ticks,
        worst_slot_error: stats.worst_slot.map(|w| w.0),
        worst_slot_vehicle: stats.worst_slot.map(|w| w.1),
        worst_slot_t: stats.worst_slot.map(|w| w.2),
        alive_at_end: alive.len(),
        in_formation_at_end: alive.iter().filter(|(_, v)| v.in_formation).count(),
        out_of_formation_at_end: alive
            .iter()
            .filter(|(_, v)| !v.in_formation)
            .map(|(i, _)| *i)
            .collect(),
        final_slot_error: stats.vehicles.iter().map(|v| v.slot_error).collect(),
        longest_contact_gap_s: stats.vehicles.iter().map(|v| v.max_age).collect(),
        stalled_s: stats.stalled_s,
        stalled_at_end: stats.stalled,
        in_formation_ratio: IN_FORMATION,
        near_collision_ratio: NEAR_COLLISION,
        stall_sdot_fraction: STALL_FRACTION,
        stall_after_s: stats.stall_after,
    }
}

/// The body's part of the outcome, for [`verdict`].
pub struct BodyOutcome {
    /// Ticks recorded and ticks planned.
    pub ticks: u64,
    pub planned: u64,
    /// Final distance of the body from the optimum (none: the field has none), and the
    /// mission's tolerance.
    pub distance: Option<f64>,
    pub tolerance: f64,
    /// Final mission time, s; the length unit's name.
    pub t: f64,
    pub unit: String,
}

/// The verdict and its reasons. In order:
/// - `interrupted`: fewer ticks recorded than planned (Ctrl-C, SIGTERM, a stop);
/// - `converged`: body within tolerance of the optimum and every live vehicle in formation;
/// - `converged, near collisions`: the same, but two vehicles came closer than
///   [`NEAR_COLLISION`] spacing at some tick (a collision, at sea): still converged;
/// - `converged, formation broken`: body within tolerance, some live vehicle out of formation;
/// - `stalled`: not converged and the body stalled at the end (ṡ ≈ 0, see the module docs);
/// - `diverged`: not converged and the body ended farther from the optimum than it started;
/// - `not converged, formation broken` / `not converged`: out of time on the way;
/// - without an optimum (e.g. a front): `formation kept` / `formation broken`.
pub fn verdict(stats: &TruthStats, body: &BodyOutcome) -> (String, Vec<String>) {
    let f = summary(stats);
    let mut reasons = Vec::new();
    let unit = if body.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", body.unit)
    };
    let interrupted = body.ticks < body.planned;
    if interrupted {
        reasons.push(format!(
            "the run was stopped at t = {} s, after {} of {} ticks",
            fmt(body.t),
            body.ticks,
            body.planned
        ));
    }
    let within = body.distance.is_some_and(|d| d <= body.tolerance);
    match body.distance {
        Some(d) if within => reasons.push(format!(
            "the body centre ended {}{unit} from the optimum, within the tolerance {}{unit}",
            fmt(d),
            fmt(body.tolerance)
        )),
        Some(d) => reasons.push(format!(
            "the body centre ended {}{unit} from the optimum, outside the tolerance {}{unit}{}",
            fmt(d),
            fmt(body.tolerance),
            stats.start_distance.map_or(String::new(), |s| format!(
                " (it started {}{unit} away)",
                fmt(s)
            ))
        )),
        None => reasons.push("the field has no optimum to converge to".into()),
    }
    let broken = !f.out_of_formation_at_end.is_empty();
    if broken {
        // The worst first, at most LIST of them named.
        const LIST: usize = 8;
        let mut worst = f.out_of_formation_at_end.clone();
        worst.sort_by(|a, b| {
            let e = |v: &u32| {
                stats.vehicles[*v as usize]
                    .slot_error
                    .unwrap_or(f64::INFINITY)
            };
            e(b).total_cmp(&e(a)).then(a.cmp(b))
        });
        let more = worst.len().saturating_sub(LIST);
        let mut list: Vec<String> = worst
            .iter()
            .take(LIST)
            .map(|&v| {
                let e = stats.vehicles[v as usize].slot_error;
                match e {
                    Some(e) => format!("vehicle {v} ({} spacings from its slot)", fmt(e)),
                    None => format!("vehicle {v} (no true state)"),
                }
            })
            .collect();
        if more > 0 {
            list.push(format!("and {more} more"));
        }
        reasons.push(format!(
            "{} of {} live vehicles ended out of formation (more than {} spacing from a slot): {}",
            f.out_of_formation_at_end.len(),
            f.alive_at_end,
            IN_FORMATION,
            list.join(", ")
        ));
    } else {
        reasons.push(format!(
            "all {} live vehicles ended in formation (within {} spacing of a slot)",
            f.alive_at_end, IN_FORMATION
        ));
    }
    if stats.stalled {
        reasons.push(format!(
            "the body stalled from t = {} s to the end (ṡ below {} v0; why: {})",
            fmt(stats.slow_since.unwrap_or(body.t)),
            STALL_FRACTION,
            stats.stall_why
        ));
    } else if stats.stalled_s > 0.0 {
        reasons.push(format!(
            "the body stalled for {} s in all, but moved again",
            fmt(stats.stalled_s)
        ));
    }
    if f.max_v_true_over_vu > 1.0 {
        reasons.push(format!(
            "V from the true states reached {} V_U (the coordinator saw at most {} V_U); above V_U for {:.1}% of ticks",
            fmt(f.max_v_true_over_vu),
            fmt(f.max_v_seen_over_vu),
            100.0 * f.share_ticks_v_true_above_vu
        ));
    }
    if f.near_collision_ticks > 0 {
        if let (Some(r), Some(t), Some([a, b])) =
            (f.min_pair_ratio, f.min_pair_t, f.min_pair_vehicles)
        {
            reasons.push(format!(
                "vehicles {a} and {b} came within {} spacing of each other at t = {} s (near collision: below {}; {} ticks)",
                fmt(r),
                fmt(t),
                NEAR_COLLISION,
                f.near_collision_ticks
            ));
        }
    }
    let diverged = match (body.distance, stats.start_distance) {
        (Some(d), Some(s)) => d > s,
        _ => false,
    };
    let verdict = if interrupted {
        "interrupted"
    } else if body.distance.is_none() {
        if broken {
            "formation broken"
        } else {
            "formation kept"
        }
    } else if within && !broken && f.near_collision_ticks > 0 {
        "converged, near collisions"
    } else if within && !broken {
        "converged"
    } else if within {
        "converged, formation broken"
    } else if stats.stalled {
        "stalled"
    } else if diverged {
        "diverged"
    } else if broken {
        "not converged, formation broken"
    } else {
        "not converged"
    };
    (verdict.to_string(), reasons)
}

/// True for the verdicts that mean converged: the body within tolerance of the optimum AND
/// every live vehicle in formation at the end ([`verdict`]).
pub fn is_converged(verdict: &str) -> bool {
    verdict == "converged" || verdict == "converged, near collisions"
}

/// A figure for a sentence: 4 significant digits (exponent form below 1e-3 and from 1e6).
pub fn fmt(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..6).contains(&mag) {
        let decimals = (3 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}
