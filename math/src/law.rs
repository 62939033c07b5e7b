//! The vehicle's control law as an extension point: [`ControlLaw`] computes u_i of one
//! vehicle from what it knows, [`PaperLaw`] is the law of the paper ((II.1), blended with
//! the homing law of [`super::rejoin`] while vehicles rejoin), the one every shipped binary
//! flies under `control.law = "paper"`; [`RobustLaw`] (`super::robust`) the one it flies under
//! `control.law = "robust"`, equal to [`PaperLaw`] when every neighbour is fresh. A user's own law implements [`ControlLaw`] and is handed to the vehicle
//! (`vehicle_agent::Vehicle::with_law`); integration (ẍ_i = u_i) stays the vehicle's.

use super::control::control_law;
use super::potential::PairPotential;
use super::rejoin::{blended_control_law, Homing, Neighbour};
use super::Vec3;

pub use super::robust::RobustLaw;

/// What one vehicle knows for one control step (from the newest body command it sees).
#[derive(Clone, Copy, Debug)]
pub struct ControlInputs<'a> {
    /// Virtual leader positions b_l(s) (III.3), length unit.
    pub leaders: &'a [Vec3],
    /// Positions of the other vehicles (swarm snapshot, ordered by id, self excluded).
    pub neighbours: &'a [Vec3],
    /// Scaled inter-vehicle potential V_I (III.3).
    pub inter: PairPotential,
    /// Scaled vehicle–leader potential V_h (III.3).
    pub leader: PairPotential,
    /// Damping gain, K = damping·I in (II.1), 1/s.
    pub damping: f64,
    /// Homing weight σ_j of each neighbour (same order; 0 for a vehicle not rejoining;
    /// empty: all 0), [`super::rejoin`].
    pub neighbour_sigmas: &'a [f64],
    /// The slot of each neighbour that rejoins (its ghost, same order; ignored where
    /// σ_j = 0), length unit.
    pub neighbour_slots: &'a [Vec3],
    /// This vehicle's own homing while it rejoins (None: it flies (II.1)).
    pub homing: Option<Homing>,
    /// Last known velocity of each neighbour (same order; empty: unknown), length unit/s.
    pub neighbour_velocities: &'a [Vec3],
    /// Age of each neighbour's position (same order; empty: all 0), s: how long ago the
    /// state was taken that `neighbours` holds moved with the body.
    pub neighbour_ages: &'a [f64],
    /// This vehicle's own slot in the design, length unit (None: not known).
    pub slot: Option<Vec3>,
    /// Velocity of the virtual body centre, length unit/s.
    pub body_velocity: Vec3,
    /// Relative growth rate of the body, k̇/k (1/s): the body's points move at
    /// `ṙ + (k̇/k)(p − r)` (III.3). 0 when not known (no committed path).
    pub body_growth: f64,
    /// Centre r of the virtual body, length unit (with `body_growth`).
    pub body_centre: Vec3,
    /// The current this vehicle believes carries it, length unit/s (zero in still water
    /// or when not estimated): its velocity over the ground is the velocity the law is
    /// given (through the water) plus this.
    pub current: Vec3,
    /// Where the hulls of lost vehicles are (length unit; they stay where they were last
    /// known, not moved with the body; empty: none). The robust law keeps clear of them
    /// ([`super::hull`]); the paper's law does not know of them.
    pub hulls: &'a [Vec3],
}

impl<'a> ControlInputs<'a> {
    /// The inputs of (II.1) alone: leaders b_l(s) and neighbours (length unit), the scaled
    /// potentials V_I and V_h, the damping gain (1/s); nobody rejoins, no neighbour velocity,
    /// age or slot is known, the body is at rest. The inputs beyond the paper are set on
    /// top with the struct update syntax (`ControlInputs { homing, ..ControlInputs::paper(…) }`).
    pub fn paper(
        leaders: &'a [Vec3],
        neighbours: &'a [Vec3],
        inter: PairPotential,
        leader: PairPotential,
        damping: f64,
    ) -> Self {
        ControlInputs {
            leaders,
            neighbours,
            inter,
            leader,
            damping,
            neighbour_sigmas: &[],
            neighbour_slots: &[],
            homing: None,
            neighbour_velocities: &[],
            neighbour_ages: &[],
            slot: None,
            body_velocity: Vec3::zeros(),
            body_growth: 0.0,
            body_centre: Vec3::zeros(),
            current: Vec3::zeros(),
            hulls: &[],
        }
    }

    /// The velocity of this vehicle's own slot as the body moves, `ṙ + (k̇/k)(p_i − r)`
    /// (length unit/s; (III.3) differentiated in time, without rotation): the body's
    /// velocity when the slot or the growth is not known.
    pub fn slot_velocity(&self) -> Vec3 {
        match self.slot {
            Some(p) if self.body_growth != 0.0 => {
                self.body_velocity + self.body_growth * (p - self.body_centre)
            }
            _ => self.body_velocity,
        }
    }

    /// What a vehicle that damps relative to its slot feeds forward, length unit/s: its
    /// slot's velocity over the ground less the current ([`ControlInputs::slot_velocity`]
    /// − `current`), so that −K ẋ on the velocity through the water plus K times this is
    /// −K (ẋ + ĉ − ṗ_i), damping over the ground relative to the slot.
    pub fn follow_velocity(&self) -> Vec3 {
        self.slot_velocity() - self.current
    }

    /// True while this vehicle or a neighbour rejoins (some homing weight is > 0).
    pub fn rejoining(&self) -> bool {
        self.homing.is_some() || self.neighbour_sigmas.iter().any(|s| *s > 0.0)
    }
}

/// A vehicle's control law: the acceleration u_i (length unit/s²) of a vehicle at
/// `position` (length unit) with `velocity` (length unit/s). Pure: the same inputs give
/// the same u_i, bit for bit, in every process (the lockstep run reproduces the simulator
/// only so).
pub trait ControlLaw: Send + Sync + std::fmt::Debug {
    /// u_i for one step.
    fn control(&self, position: &Vec3, velocity: &Vec3, inputs: &ControlInputs<'_>) -> Vec3;
}

/// The law of the paper: u_i of (II.1) from the neighbours, the virtual leaders and the
/// damping (their velocities, ages, this vehicle's slot and the body's velocity unused); while this vehicle or a neighbour rejoins, the blended law of
/// [`super::rejoin::blended_control_law`] (equal to (II.1) bit for bit when nobody does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PaperLaw;

impl ControlLaw for PaperLaw {
    fn control(&self, position: &Vec3, velocity: &Vec3, inputs: &ControlInputs<'_>) -> Vec3 {
        if inputs.rejoining() {
            let weighted: Vec<Neighbour> = inputs
                .neighbours
                .iter()
                .enumerate()
                .map(|(j, p)| Neighbour {
                    position: *p,
                    sigma: inputs.neighbour_sigmas.get(j).copied().unwrap_or(0.0),
                    slot: inputs.neighbour_slots.get(j).copied().unwrap_or(*p),
                })
                .collect();
            blended_control_law(
                position,
                velocity,
                inputs.homing.as_ref(),
                &weighted,
                inputs.leaders,
                &inputs.inter,
                &inputs.leader,
                inputs.damping,
            )
        } else {
            control_law(
                position,
                velocity,
                inputs.neighbours,
                inputs.leaders,
                &inputs.inter,
                &inputs.leader,
                inputs.damping,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_law_is_ii_1_when_nobody_rejoins() {
        let inter = PairPotential::new(1.0, 1.0, 1.5).unwrap();
        let leader = PairPotential::new(2.0, 2.0, 8.0).unwrap();
        let x = Vec3::new(0.1, -0.2, 0.0);
        let v = Vec3::new(0.3, 0.0, 0.0);
        let neighbours = [Vec3::new(0.9, 0.0, 0.0), Vec3::new(-0.5, 0.7, 0.0)];
        let leaders = [Vec3::new(1.5, 1.0, 0.0)];
        let inputs = ControlInputs {
            neighbour_sigmas: &[0.0, 0.0],
            ..ControlInputs::paper(&leaders, &neighbours, inter, leader, 0.7)
        };
        assert!(!inputs.rejoining());
        let u = PaperLaw.control(&x, &v, &inputs);
        let expected = control_law(&x, &v, &neighbours, &leaders, &inter, &leader, 0.7);
        assert_eq!(u, expected, "bit for bit");
    }
}
