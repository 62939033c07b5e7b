//! The `formation` object of `summary.json`, from the running truth figures.

use vbap_math::fit::{IN_FORMATION, NEAR_COLLISION};
use vbap_mission::rundir::FormationSummary;

use super::{TruthStats, VehicleTruth, STALL_FRACTION};

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
        all_in_contact_t: stats.all_heard_t,
        share_ticks_v_true_above_vu_after_contact: (stats.ticks_after_contact > 0)
            .then(|| stats.ticks_v_above_after_contact as f64 / stats.ticks_after_contact as f64),
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
