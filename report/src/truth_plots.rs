//! Pictures of what the vehicles truly did, from the truth files of a run directory:
//! `formation.csv` (per vehicle and tick: contact state, age of the coordinator's newest
//! information, distance from its slot, nearest neighbour, in formation or not), `truth.csv`
//! (per tick: V of (II.2) from the true states beside the coordinator's own, nearest pair,
//! counts) and the events of `events.jsonl`.
//!
//! - [`CONTACT_SVG`], the contact timeline: one row per vehicle over mission time, coloured by
//!   its contact state (in contact, surfaced, submerged, link down, rejoining, dead), with the
//!   deliveries (ticks at which the coordinator's information about the vehicle was renewed:
//!   its age dropped) as dark ticks along the bottom of the row, the vehicle's own events as
//!   symbols on its row, the fleet's events (redesigns, stalls, ...) as labelled dashed lines
//!   across all rows, two fleet rows on top (formation broken, fleet stalled, from the
//!   events), and below, the age of the coordinator's information per vehicle.
//! - panels of `timeseries_formation.svg`: each vehicle's distance from its slot ÷ design
//!   spacing against the in-formation threshold, and the nearest pair ÷ spacing.
//!
//! Older runs have no truth files: the readers return `None` and the pictures are left out.
//! A truth file that does not follow its schema is reported (a warning) and left out too: a
//! plot never fails a run.

mod contact;
mod panels;
mod read;

use std::fs::File;

use crate::plot::chart::PLOT_W;
use crate::plot::style::CONTACT_STATES;
use vbap_mission::config::Mission;
use vbap_wire::rundir::RunDir;

use crate::plot::decimate::MAX_POINTS;

pub use contact::render_contact_svg;
pub use panels::{nearest_pair_panel, slot_error_panel};
pub use read::{Formation, Lane, Truth};

/// File name of the contact timeline.
pub const CONTACT_SVG: &str = "contact.svg";
/// File name of the per-vehicle truth (written by the recorder).
pub const FORMATION_CSV: &str = "formation.csv";
/// File name of the per-tick truth (written by the recorder).
pub const TRUTH_CSV: &str = "truth.csv";
/// Most vehicles drawn one line each in a panel; beyond, the worst only.
pub const MAX_VEHICLE_LINES: usize = 12;
/// An information age above this many ticks is a silence (out of contact).
pub const SILENCE_TICKS: u64 = 10;
/// Most silences (age sawteeth) of one vehicle drawn as its own line in the age panel;
/// beyond, the lines would cover each other: the oldest over the vehicles is drawn instead.
pub const MAX_SAWTEETH: u64 = 24;

const N_STATES: usize = CONTACT_STATES.len();

/// A threshold of the truth metrics as `summary.json` records it in its `formation` object
/// (`in_formation_ratio`: the largest slot error ÷ spacing still in formation;
/// `near_collision_ratio`: a pair closer than this × spacing is a near collision).
pub fn summary_ratio(dir: &RunDir, key: &str) -> Option<f64> {
    let text = std::fs::read_to_string(dir.summary()).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    json.get("formation")?.get(key)?.as_f64()
}

/// Decimation bucket for `ticks` rows and about `points` points.
fn bucket(ticks: u64, points: usize) -> u64 {
    ticks.div_ceil((points / 4).max(1) as u64).max(1)
}

/// `formation.csv` of `dir` over `t_range` (s); None when absent (an older run) or not
/// readable (a warning says why).
pub fn read_formation_or_warn(
    dir: &RunDir,
    mission: &Mission,
    t_range: (f64, f64),
) -> Option<Formation> {
    let path = dir.root.join(FORMATION_CSV);
    let file = File::open(&path).ok()?;
    let n = mission.vehicles.count.max(1);
    let points = (MAX_POINTS / n.min(MAX_VEHICLE_LINES)).max(400);
    let read = Formation::read(
        &path,
        file,
        mission.mission.dt,
        t_range,
        PLOT_W as usize,
        bucket(mission.ticks(), points),
    );
    match read {
        Ok(mut f) => {
            f.threshold = summary_ratio(dir, "in_formation_ratio");
            f.near_collision = summary_ratio(dir, "near_collision_ratio");
            Some(f)
        }
        Err(e) => {
            tracing::warn!(error = %format!("{e:#}"), "contact and slot-error plots left out");
            None
        }
    }
}

/// `truth.csv` of `dir`; None when absent (an older run) or not readable (a warning says
/// why).
pub fn read_truth_or_warn(dir: &RunDir, mission: &Mission) -> Option<Truth> {
    let near_collision = summary_ratio(dir, "near_collision_ratio");
    let path = dir.root.join(TRUTH_CSV);
    let file = File::open(&path).ok()?;
    match Truth::read(&path, file, bucket(mission.ticks(), MAX_POINTS / 2)) {
        Ok(t) => Some(Truth {
            near_collision,
            ..t
        }),
        Err(e) => {
            tracing::warn!(error = %format!("{e:#}"), "true V and nearest-pair plots left out");
            None
        }
    }
}

#[cfg(test)]
mod tests;
