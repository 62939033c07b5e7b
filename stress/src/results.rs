//! What a campaign records: its plan (`plan.json`), each flight's dimensions and result
//! (a line of `results.jsonl`) and its name; written by [`crate::campaign`], read by
//! [`crate::table`].

use serde::{Deserialize, Serialize};

use crate::draw::Draw;
use crate::judge::Judgement;

/// `plan.json`: the parts of [`Config`] that decide the results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub missions: u64,
    pub seed: u64,
    pub laws: Vec<String>,
    pub v_bound: f64,
    pub shrink: bool,
    pub sets: Vec<String>,
    /// The declared space, as `--space` prints it.
    pub space: String,
    /// The only mission indices flown (`--only`); empty: every index below `missions`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub only: Vec<u64>,
}

/// The dimensions of a flight, for the table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dims {
    pub n: usize,
    pub dim: usize,
    pub field: String,
    pub noise_fraction: f64,
    pub delay: f64,
    pub jitter: f64,
    pub loss: f64,
    pub bursty: bool,
    pub surfacing: bool,
    /// Iridium sessions on the surfacing link (false in result lines written before it was
    /// drawn).
    #[serde(default)]
    pub iridium: bool,
    /// Acoustic modems (false in result lines written before they were drawn).
    #[serde(default)]
    pub acoustic: bool,
    pub faults: usize,
    pub adapt: bool,
    pub glider: bool,
    pub current: bool,
    pub v0: f64,
    pub alpha: f64,
    pub damping: f64,
    /// `formation.min_scale` (absent in result lines written before it was drawn).
    #[serde(default)]
    pub min_scale: f64,
    /// `formation.radius` ÷ the spacing-preserving radius (1 in result lines written
    /// before it was drawn).
    #[serde(default = "crate::draw::one")]
    pub radius_factor: f64,
}

impl Dims {
    /// True when the drawn links never delay nor lose a message (no delay, jitter, loss,
    /// burst or surfacing). The robust law's link-aware parts (the envelope's clamps, the
    /// committed path, damping relative to the body) are then off: on a still field
    /// without faults the mission flies the paper's law and planner bit for bit. A
    /// `--set links.…` applied to every mission is not seen here.
    pub fn is_ideal_links(&self) -> bool {
        self.delay == 0.0
            && self.jitter == 0.0
            && self.loss == 0.0
            && !self.bursty
            && !self.surfacing
    }

    /// The dimensions of `d`.
    pub fn of(d: &Draw) -> Dims {
        Dims {
            n: d.n,
            dim: d.dim,
            field: d.field.kind.clone(),
            noise_fraction: d.noise_fraction,
            delay: d.delay,
            jitter: d.jitter,
            loss: d.loss,
            bursty: d.burst.is_some(),
            surfacing: d.surfacing.is_some(),
            iridium: d.iridium.is_some(),
            acoustic: d.acoustic.is_some(),
            faults: d.faults.len(),
            adapt: d.adapt,
            glider: d.glider.is_some(),
            current: d.current.is_some(),
            v0: d.v0,
            alpha: d.alpha,
            damping: d.damping,
            min_scale: d.min_scale,
            radius_factor: d.radius_factor,
        }
    }
}

/// One flight's line of `results.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlightResult {
    /// Mission index.
    pub mission: u64,
    /// `control.law`.
    pub law: String,
    /// Passed every criterion.
    pub pass: bool,
    /// The judgement.
    pub judgement: Judgement,
    /// The mission's dimensions.
    pub dims: Dims,
    /// The mission file kept (failures), relative to OUT.
    pub file: Option<String>,
    /// The shrunk failure (with `--shrink`): its file relative to OUT, criterion, steps.
    pub shrunk: Option<ShrunkResult>,
    /// Wall time of the flight (not part of the table), s.
    pub wall_s: f64,
}

/// The shrunk form of a failure, as recorded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShrunkResult {
    pub file: String,
    pub criterion: String,
    pub steps: Vec<String>,
    pub flights: usize,
    pub dims: Dims,
}

/// The name of flight (mission, law).
pub fn flight_name(mission: u64, law: &str) -> String {
    format!("m{mission:04}_{law}")
}
