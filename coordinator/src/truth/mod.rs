//! The formation judged from the vehicles' TRUE states, every tick (`formation.csv`,
//! `truth.csv`, the events a user needs to see, and the `formation` object, `verdict` and
//! `reasons` of `summary.json`). The recorder is omniscient (it sees the true states the
//! planner only hears about through the links); this is where that is put to use. Called
//! from [`crate::tick::plan_tick`], so `vbap sim` and `vbap run` write the same bytes; its
//! running state ([`TruthStats`]) is checkpointed with the recorder's.
//!
//! Thresholds (documented in docs/guide/runs.md):
//! - in formation: slot error ≤ [`IN_FORMATION`] × spacing;
//! - near collision: a pair closer than [`NEAR_COLLISION`] × spacing;
//! - stall: ṡ below [`STALL_FRACTION`] × v0 for longer than [`TruthStats::stall_after`]
//!   (the time the body needs to cross one design spacing at v0, at least
//!   [`DEBOUNCE_TICKS`] ticks); it ends when ṡ is back above twice that fraction;
//! - silence: a vehicle in contact by the schedule whose newest delivered state is older
//!   than `delay + jitter + SILENCE_TICKS · dt`, plus the sessions' wait under Iridium
//!   (`LinksSection::session_wait`, [`TruthStats::silence_after`]);
//! - formation broken / restored events are debounced: the new state must hold for
//!   [`DEBOUNCE_TICKS`] ticks; a near-collision event re-arms once the closest pair is back
//!   beyond twice the threshold.

use std::collections::BTreeSet;

use vbap_math::body::BodyRates;
use vbap_math::fit::potential_energy_sparse;
pub use vbap_math::fit::{IN_FORMATION, NEAR_COLLISION};
use vbap_math::formation::FormationDesign;
use vbap_math::rejoin::{blended_lyapunov_terms, homing_weight, Homing};
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{Event, FormationRow, TruthRow};

use crate::fleet::Fleet;
use crate::planner::{Command, Report};

mod running;
mod silence;
mod slots;
mod summary;
mod verdict;

use running::At;
use slots::Scene;
pub use summary::summary;
pub use verdict::{choose, verdict, BodyOutcome, Facts, LocalOptimum, Tracking};

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
    /// In contact (by the schedule) at least once so far: it has heard a plan.
    pub heard: bool,
}

/// The running truth figures (checkpointed).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TruthStats {
    pub vehicles: Vec<VehicleTruth>,
    pub max_v_true: f64,
    pub max_v_seen: f64,
    pub ticks: u64,
    pub ticks_v_above: u64,
    /// Mission time when every vehicle had been in contact at least once (a glider that
    /// has never surfaced flies the plan it was deployed with), s.
    pub all_heard_t: Option<f64>,
    /// Ticks since `all_heard_t`, and those of them with the true V above V_U.
    pub ticks_after_contact: u64,
    pub ticks_v_above_after_contact: u64,
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
            mission.formation_dim(),
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
            silence_after: mission.links.delay
                + mission.links.jitter
                + mission.links.session_wait()
                + SILENCE_TICKS * dt,
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
/// tick's deliveries, `distance` the body centre's distance from the optimum (length
/// unit; none without one). The rows of `formation.csv` and `truth.csv` and the events of
/// the tick, in the order: contact events (by vehicle), near collision, formation broken
/// or restored, stall.
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
    let mut events = Vec::new();
    if k == 0 || stats.start_distance.is_none() {
        stats.start_distance = stats.start_distance.or(distance);
    }
    let members: BTreeSet<u32> = command.members.iter().copied().collect();
    let v_true = true_lyapunov(truth, &members, command, design) / v_u;
    let v_seen = command.terms.v / v_u;
    let scene = Scene {
        k,
        t,
        dt,
        truth,
        members: &members,
        command,
        design,
        fleet,
        dim: mission.formation_dim(),
    };
    let (rows, tally) = slots::vehicles(stats, &scene, &mut events);
    let at = At { k, t };
    running::extremes(stats, at, v_true, v_seen, &tally, &mut events);
    running::after_first_contact(stats, t, v_true);
    running::formation_state(stats, at, &tally, &mut events);
    let sdot_ratio = running::stalls(
        stats,
        at,
        dt,
        mission.body.v0,
        command,
        (v_seen, v_true),
        tally.stale_member,
        &mut events,
    );
    TruthTick {
        rows,
        row: TruthRow {
            t,
            k,
            v_true_over_vu: v_true,
            v_seen_over_vu: v_seen,
            min_pair_ratio: tally.min_pair.map(|(r, ..)| r),
            max_slot_error: tally.max_slot.map(|(e, _)| e),
            n_alive: tally.n_alive,
            n_in_formation: tally.n_in,
            sdot_over_v0: sdot_ratio,
        },
        events,
    }
}

/// V of (II.2) from the true states of the formation's `members` about the body of
/// `command` with `design` (field-independent energy units, not yet ÷ V_U):
/// max(0, ½ Σ|v|² + potential − E_n), as `lyapunov_terms` (the sparse sum of the
/// potential costs O(n) per vehicle near the formation instead of O(n²)).
///
/// A member still flying home to its slot (`command.rejoining`, `vbap_math::rejoin`) is
/// not yet admitted into the formation: it counts as the coordinator's `V_w` counts it,
/// weight `1 − σ` at its TRUE position and `σ` at its slot, `σ` the homing weight of its
/// true distance from the slot. So it enters V in full only within the capture radius of
/// its slot (a tenth of the spacing): V at the switch counts its true offset there, not
/// the plateaus of every pair with a vehicle that is still far away.
fn true_lyapunov(
    truth: &[Report],
    members: &BTreeSet<u32>,
    command: &Command,
    design: &FormationDesign,
) -> f64 {
    let admitted: Vec<&Report> = truth.iter().filter(|q| members.contains(&q.id)).collect();
    if !command.rejoining.is_empty() {
        return true_blended_lyapunov(&admitted, command, design);
    }
    let (pos, vel): (Vec<_>, Vec<_>) = admitted.iter().map(|q| (q.position, q.velocity)).unzip();
    let kinetic: f64 = vel.iter().map(|v| v.norm_squared()).sum();
    let potential = potential_energy_sparse(
        &pos,
        &command.body.leader_positions(design),
        &command.body.scaled_inter(design),
        &command.body.scaled_leader(design),
    );
    (0.5 * kinetic + potential - design.equilibrium_energy(pos.len())).max(0.0)
}

/// [`true_lyapunov`] while members rejoin: `V_w` of `vbap_math::rejoin` from the true
/// states, each rejoining member's `σ` from its true distance to its slot.
fn true_blended_lyapunov(members: &[&Report], command: &Command, design: &FormationDesign) -> f64 {
    let spacing = command.body.scale * design.neighbour_spacing();
    let positions: Vec<Vec3> = members.iter().map(|q| q.position).collect();
    let velocities: Vec<Vec3> = members.iter().map(|q| q.velocity).collect();
    let homings: Vec<Option<(Homing, Vec3)>> = members
        .iter()
        .map(|q| {
            command
                .rejoining
                .iter()
                .find(|(id, _)| *id == q.id)
                .map(|(_, slot)| {
                    let sigma = homing_weight((slot - q.position).norm(), spacing);
                    // The reference velocity only enters the power, not V.
                    let velocity = q.velocity;
                    (Homing { sigma, velocity }, *slot)
                })
        })
        .collect();
    blended_lyapunov_terms(
        &positions,
        &velocities,
        &homings,
        &command.body,
        &BodyRates::zero(),
        design,
        0.0,
    )
    .v
}

/// True for the verdicts that mean converged: the body within tolerance of the optimum AND
/// every live vehicle in formation at the end ([`verdict`]); for a moving optimum, tracked
/// over the last quarter of the run.
pub fn is_converged(verdict: &str) -> bool {
    matches!(
        verdict,
        "converged" | "converged, near collisions" | "tracking" | "tracking, near collisions"
    )
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
