//! One vehicle's dynamics: the double integrator ẍ_i = u_i stepped under a control law
//! (pure: no IPC).

use vbap_math::control::integrate;
use vbap_math::law::{ControlInputs, ControlLaw, PaperLaw};
use vbap_math::potential::PairPotential;
use vbap_math::Vec3;

/// What an agent needs from the coordinator for one step (the inputs of a
/// [`ControlLaw`]).
pub type AgentInputs<'a> = ControlInputs<'a>;

/// How far (fraction of the spacing d0) one step's acceleration may move a vehicle before
/// the step is split ([`Agent::step_with`]).
pub const SUBSTEP_REACH: f64 = 0.05;

/// The most substeps one step is split into.
pub const MAX_SUBSTEPS: usize = 64;

/// One vehicle: its own state and dynamics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agent {
    /// Vehicle id.
    pub id: u32,
    /// Mission dimension (2 or 3); in 2-D z stays 0.
    pub dim: usize,
    /// Position x_i, length unit.
    pub position: Vec3,
    /// Velocity ẋ_i, length unit/s.
    pub velocity: Vec3,
}

impl Agent {
    /// One control step of length `dt` (s) under the paper's law ([`PaperLaw`]): u_i from
    /// (II.1) — blended with the homing law of `vbap_math::rejoin` while this vehicle or
    /// a neighbour rejoins — then ẍ_i = u_i integrated (semi-implicit Euler). Returns u_i.
    pub fn step(&mut self, inputs: &AgentInputs<'_>, dt: f64) -> Vec3 {
        self.step_with(&PaperLaw, inputs, dt)
    }

    /// One control step of length `dt` (s) under `law`: u_i = `law.control(..)`, then
    /// ẍ_i = u_i integrated (semi-implicit Euler); in 2-D z stays 0. Returns u_i.
    ///
    /// A step whose acceleration alone would move the vehicle by more than
    /// [`SUBSTEP_REACH`] of the spacing d0 (`|u| dt² > SUBSTEP_REACH · d0`: a pair far
    /// inside its repulsion, as when a restarted vehicle comes back next to a member) is
    /// integrated in m equal substeps, u_i recomputed at each from the same inputs,
    /// `m = ⌈√(|u| dt² / (SUBSTEP_REACH · d0))⌉` (at most [`MAX_SUBSTEPS`]): one Euler step
    /// of that stiff force threw the vehicle at 20 spacings per second, an energy the
    /// continuous (II.1) never gives it. Any other step is the single step it always was,
    /// bit for bit.
    pub fn step_with(&mut self, law: &dyn ControlLaw, inputs: &AgentInputs<'_>, dt: f64) -> Vec3 {
        let u = law.control(&self.position, &self.velocity, inputs);
        let reach = SUBSTEP_REACH * inputs.inter.d0;
        let kick = u.norm() * dt * dt;
        let (x, v) = if kick > reach && reach > 0.0 {
            let m = (kick / reach).sqrt().ceil().min(MAX_SUBSTEPS as f64) as usize;
            let h = dt / m as f64;
            let (mut x, mut v) = integrate(&self.position, &self.velocity, &u, h);
            for _ in 1..m {
                let u = law.control(&x, &v, inputs);
                (x, v) = integrate(&x, &v, &u, h);
            }
            (x, v)
        } else {
            integrate(&self.position, &self.velocity, &u, dt)
        };
        self.position = x;
        self.velocity = v;
        if self.dim == 2 {
            self.position.z = 0.0;
            self.velocity.z = 0.0;
        }
        u
    }

    /// Holds station when nothing is heard from the coordinator (docs/ARCHITECTURE.md §7): damping and
    /// the last known virtual leaders only, no neighbours.
    pub fn hold_station(
        &mut self,
        last_leaders: &[Vec3],
        leader: &PairPotential,
        damping: f64,
        dt: f64,
    ) -> Vec3 {
        self.hold_station_with(&PaperLaw, last_leaders, leader, damping, dt)
    }

    /// [`Agent::hold_station`] under `law`.
    pub fn hold_station_with(
        &mut self,
        law: &dyn ControlLaw,
        last_leaders: &[Vec3],
        leader: &PairPotential,
        damping: f64,
        dt: f64,
    ) -> Vec3 {
        let inputs = Self::hold_inputs(last_leaders, leader, damping);
        self.step_with(law, &inputs, dt)
    }

    /// The inputs of holding station: the last known virtual leaders `last_leaders` with
    /// the potential `leader` and `damping` (1/s), no neighbours.
    pub fn hold_inputs<'a>(
        last_leaders: &'a [Vec3],
        leader: &PairPotential,
        damping: f64,
    ) -> AgentInputs<'a> {
        let no_neighbours = PairPotential {
            alpha: 0.0,
            d0: 1.0,
            d1: 0.0,
        };
        AgentInputs::paper(last_leaders, &[], no_neighbours, *leader, damping)
    }
}
