//! Keeping out of land (beyond the paper: the paper's plane has no coast).
//!
//! Two pure pieces: [`repulsion`], a control term that pushes a vehicle away from a coast
//! it comes near (added to u_i of (II.1)), and [`slide`], the hard constraint on a motion:
//! a step that would end on land keeps only its component along the coast, or stops.
//! The land itself is whatever the caller's closures say (a mask from a mission).

use crate::Vec3;

/// The repulsive term near land.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Avoidance {
    /// Distance from land below which the term acts, length unit (> 0).
    pub distance: f64,
    /// Largest push, at the coast itself, length unit/s² (≥ 0).
    pub gain: f64,
}

/// The control term pushing away from land, length unit/s²: with `clearance` = (d, n), the
/// distance d to the nearest land and the unit direction n pointing away from it,
/// gain · (1 − d / distance)² · n while d < distance, zero farther out or without land
/// near. Continuous in d (it vanishes at `distance`), largest at the coast.
pub fn repulsion(clearance: Option<(f64, Vec3)>, a: &Avoidance) -> Vec3 {
    match clearance {
        Some((d, n)) if d < a.distance && a.distance > 0.0 => {
            let s = 1.0 - d.max(0.0) / a.distance;
            n * (a.gain * s * s)
        }
        _ => Vec3::zeros(),
    }
}

/// Where a point moving from `from` to `to` ends when land must not be entered: `to` when
/// it is not land (`is_land`); else the move without its component into the coast
/// (`away`: the unit direction away from the nearest land at `from`, if known), when that
/// ends off land; else `from` (stopped). `from` is assumed off land.
pub fn slide(from: &Vec3, to: &Vec3, is_land: impl Fn(&Vec3) -> bool, away: Option<Vec3>) -> Vec3 {
    if !is_land(to) {
        return *to;
    }
    if let Some(n) = away {
        let step = to - from;
        let into = step.dot(&n);
        if into < 0.0 {
            let along = from + (step - n * into);
            if !is_land(&along) {
                return along;
            }
        }
    }
    *from
}
