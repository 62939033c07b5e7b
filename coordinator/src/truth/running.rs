//! The running figures of a tick of truth: the extremes, the near collisions, the
//! formation broken and restored (debounced) and the stalls.

use vbap_math::fit::NEAR_COLLISION;
use vbap_mission::rundir::Event;

use super::slots::Tally;
use super::{event, TruthStats, DEBOUNCE_TICKS, STALL_FRACTION};
use crate::planner::Command;

/// Tick `k` at mission time `t` (s).
#[derive(Clone, Copy)]
pub(super) struct At {
    pub k: u64,
    pub t: f64,
}

/// Counts the tick at time `t` (s) towards the share of ticks with the true V ÷ V_U
/// (`v_true`) above 1 once every vehicle has been in contact at least once (dead ones
/// count as heard): before that, some vehicle still flies the plan it was deployed with.
pub(super) fn after_first_contact(stats: &mut TruthStats, t: f64, v_true: f64) {
    for v in stats.vehicles.iter_mut() {
        if matches!(v.contact.as_str(), "contact" | "surfaced") {
            v.heard = true;
        }
    }
    if stats.all_heard_t.is_none() && stats.vehicles.iter().all(|v| v.heard || !v.alive) {
        stats.all_heard_t = Some(t);
    }
    if stats.all_heard_t.is_some() {
        stats.ticks_after_contact += 1;
        if v_true > 1.0 {
            stats.ticks_v_above_after_contact += 1;
        }
    }
}

/// Brings the extremes up to date: V ÷ V_U (II.2) from the true states (`v_true`) and as
/// the coordinator saw it (`v_seen`), the closest pair (a `near_collision` event when it
/// comes below [`NEAR_COLLISION`] spacing, re-armed once it is back beyond twice that)
/// and the worst slot error.
pub(super) fn extremes(
    stats: &mut TruthStats,
    at: At,
    v_true: f64,
    v_seen: f64,
    tally: &Tally,
    events: &mut Vec<Event>,
) {
    let At { k, t } = at;
    stats.ticks += 1;
    stats.max_v_true = stats.max_v_true.max(v_true);
    stats.max_v_seen = stats.max_v_seen.max(v_seen);
    if v_true > 1.0 {
        stats.ticks_v_above += 1;
    }
    if let Some((r, a, b)) = tally.min_pair {
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
    if let Some((e, id)) = tally.max_slot {
        if stats.worst_slot.is_none_or(|(m, ..)| e > m) {
            stats.worst_slot = Some((e, id, t));
        }
    }
}

/// The formation broken (some live vehicle out of formation) or restored, debounced: the
/// new state must hold for [`DEBOUNCE_TICKS`] ticks before it is an event.
pub(super) fn formation_state(
    stats: &mut TruthStats,
    at: At,
    tally: &Tally,
    events: &mut Vec<Event>,
) {
    let At { k, t } = at;
    let broken = !tally.out.is_empty();
    if broken == stats.broken {
        stats.pending = None;
        return;
    }
    let (since_k, since_t) = *stats.pending.get_or_insert((k, t));
    if k + 1 - since_k >= DEBOUNCE_TICKS {
        stats.broken = broken;
        stats.pending = None;
        let worst = tally
            .max_slot
            .map(|(e, id)| serde_json::json!({ "vehicle": id, "slot_error": e }));
        events.push(event(
            t,
            k,
            if broken {
                "formation_broken"
            } else {
                "formation_restored"
            },
            None,
            serde_json::json!({ "vehicles": tally.out, "since": since_t, "worst": worst }),
        ));
    }
}

/// Why the body stalled: holding, V (II.2) as the coordinator saw it (`v_seen`, ÷ V_U)
/// at or above V_U, a member's state older than the silence threshold
/// (`stale_member`), V above V_U/2, or just slow.
pub(super) fn stall_reason(holding: bool, v_seen: f64, stale_member: bool) -> &'static str {
    if holding {
        "holding"
    } else if v_seen >= 1.0 {
        "V above V_U"
    } else if stale_member {
        "waiting for reports"
    } else if v_seen >= 0.5 {
        "V above V_U/2"
    } else {
        "slow"
    }
}

/// Follows the stalls: ṡ (IV.4) of `command` below [`STALL_FRACTION`] × v0 (`v0`, length
/// unit/s) for longer than [`TruthStats::stall_after`] is a stall (`stall_began`); it
/// ends (`stall_ended`) when ṡ is back above twice that fraction. `dt`: the tick length,
/// s. Returns ṡ ÷ v0 (0 without v0).
#[allow(clippy::too_many_arguments)]
pub(super) fn stalls(
    stats: &mut TruthStats,
    at: At,
    dt: f64,
    v0: f64,
    command: &Command,
    (v_seen, v_true): (f64, f64),
    stale_member: bool,
    events: &mut Vec<Event>,
) -> f64 {
    let At { k, t } = at;
    let sdot_ratio = if v0 > 0.0 { command.sdot / v0 } else { 0.0 };
    if sdot_ratio < STALL_FRACTION {
        let since = *stats.slow_since.get_or_insert(t);
        if !stats.stalled && t - since >= stats.stall_after {
            stats.stalled = true;
            let why = stall_reason(command.holding, v_seen, stale_member);
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
    sdot_ratio
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truth::VehicleTruth;

    /// The share after first contact counts only once every live vehicle was in contact.
    #[test]
    fn ticks_count_after_every_vehicle_was_heard() {
        let glider = |contact: &str, alive: bool| VehicleTruth {
            contact: contact.into(),
            alive,
            ..VehicleTruth::default()
        };
        let mut stats = TruthStats {
            vehicles: vec![glider("surfaced", true), glider("submerged", true)],
            ..TruthStats::default()
        };
        after_first_contact(&mut stats, 0.0, 5.0);
        assert_eq!((stats.all_heard_t, stats.ticks_after_contact), (None, 0));
        // Vehicle 0 dives again: it has still been heard.
        stats.vehicles[0].contact = "submerged".into();
        stats.vehicles[1].contact = "surfaced".into();
        after_first_contact(&mut stats, 10.0, 5.0);
        assert_eq!(stats.all_heard_t, Some(10.0));
        stats.vehicles[1].contact = "submerged".into();
        after_first_contact(&mut stats, 20.0, 0.5);
        assert_eq!(stats.ticks_after_contact, 2);
        assert_eq!(stats.ticks_v_above_after_contact, 1);
        // A dead vehicle that never surfaced does not hold the count back.
        let mut stats = TruthStats {
            vehicles: vec![glider("contact", true), glider("dead", false)],
            ..TruthStats::default()
        };
        after_first_contact(&mut stats, 3.0, 0.0);
        assert_eq!(stats.all_heard_t, Some(3.0));
    }

    #[test]
    fn the_reasons_of_a_stall_in_their_order() {
        assert_eq!(stall_reason(true, 2.0, true), "holding");
        assert_eq!(stall_reason(false, 1.0, true), "V above V_U");
        assert_eq!(stall_reason(false, 0.9, true), "waiting for reports");
        assert_eq!(stall_reason(false, 0.5, false), "V above V_U/2");
        assert_eq!(stall_reason(false, 0.49, false), "slow");
    }

    #[test]
    fn a_broken_formation_is_an_event_after_the_debounce_only() {
        let mut stats = TruthStats::default();
        let tally = Tally {
            out: vec![3],
            max_slot: Some((0.5, 3)),
            ..Tally::default()
        };
        let mut events = Vec::new();
        for k in 0..DEBOUNCE_TICKS - 1 {
            formation_state(&mut stats, At { k, t: k as f64 }, &tally, &mut events);
        }
        assert!(events.is_empty() && !stats.broken);
        let k = DEBOUNCE_TICKS - 1;
        formation_state(&mut stats, At { k, t: k as f64 }, &tally, &mut events);
        assert_eq!(events.len(), 1);
        assert_eq!(events[0].kind, "formation_broken");
        assert_eq!(events[0].detail["since"], 0.0);
        assert!(stats.broken && stats.pending.is_none());
        // A single good tick cancels a pending restoration.
        let good = Tally::default();
        formation_state(&mut stats, At { k: 30, t: 30.0 }, &good, &mut events);
        assert!(stats.pending.is_some());
        formation_state(&mut stats, At { k: 31, t: 31.0 }, &tally, &mut events);
        assert!(stats.pending.is_none() && events.len() == 1);
    }

    #[test]
    fn a_near_collision_is_reported_once_until_re_armed() {
        let mut stats = TruthStats::default();
        let mut events = Vec::new();
        let close = Tally {
            min_pair: Some((0.5 * NEAR_COLLISION, 0, 1)),
            ..Tally::default()
        };
        let between = Tally {
            min_pair: Some((1.5 * NEAR_COLLISION, 0, 1)),
            ..Tally::default()
        };
        let far = Tally {
            min_pair: Some((2.0 * NEAR_COLLISION, 0, 1)),
            ..Tally::default()
        };
        for (k, tally) in [&close, &between, &close, &far, &close].iter().enumerate() {
            let at = At {
                k: k as u64,
                t: k as f64,
            };
            extremes(&mut stats, at, 0.0, 0.0, tally, &mut events);
        }
        let near: Vec<u64> = events.iter().map(|e| e.k).collect();
        assert_eq!(near, vec![0, 4]);
        assert_eq!(stats.near_collision_ticks, 3);
        assert_eq!(stats.min_pair, Some((0.5 * NEAR_COLLISION, 0.0, 0, 1)));
    }
}
