//! `vbap-math`: the mathematics of Ögren, Fiorelli and Leonard (IEEE TAC 2004), pure functions only.
//!
//! Positions are always [`Vec3`] (metres or the mission's length unit); in 2-D missions the
//! z component is zero and stays zero. Equation numbers are those of the paper (Ögren, Fiorelli and Leonard, IEEE TAC 2004).
//!
//! Formation dynamics (Sections II–IV): [`potential`], [`formation`], [`body`], [`control`] (and
//! [`law`], the control law as an extension point),
//! [`lyapunov`], [`speed`]; who each vehicle needs to hear of, [`neighbourhood`]; [`fit`] measures the true formation against its design;
//! bringing a vehicle back from anywhere: [`rejoin`]. Beyond the paper, for links that are
//! not continuous: control with stale neighbour information ([`robust`]), the body's path
//! committed ahead for vehicles out of contact ([`schedule`]), and a redesign without a
//! jump of `V` ([`assign`], [`procrustes`], [`bumpless`]).
//! Gradient estimation (Section V): [`estimate`], [`optimal`], [`kalman`], [`convergence`],
//! [`adapt`]; the curvature of the field estimated from the readings (beyond the paper):
//! [`curvature`].
//!
//! Gridded fields from files (beyond the paper): interpolation and the local map
//! projection, [`gridmath`].
//!
//! Random streams keyed by (seed, stream, id, tick), so every process draws the same noise:
//! [`rng`].
//!
//! Beyond the paper, the motion of a real vehicle: speed, acceleration and turn limits, a
//! current, dead reckoning and keeping out of land ([`vehicle`]).
//!
//! This crate depends on no IPC, I/O, clock or logging crate: the compiler keeps it pure.

pub mod adapt;
pub mod ascent;
pub mod assign;
pub mod barrier;
pub mod body;
pub mod bumpless;
pub mod control;
pub mod convergence;
pub mod curvature;
pub mod drift;
pub mod envelope;
pub mod estimate;
pub mod fit;
pub mod formation;
pub mod gridmath;
pub mod hull;
pub mod kalman;
pub mod law;
pub mod lyapunov;
pub mod neighbourhood;
pub mod optimal;
pub mod potential;
pub mod procrustes;
pub mod rejoin;
pub mod rng;
pub mod robust;
pub mod schedule;
pub mod speed;
pub mod vehicle;

/// A point or vector in the inertial frame (length unit of the mission).
pub type Vec3 = nalgebra::Vector3<f64>;
/// A 3×3 matrix (Hessians, rotations, second moments).
pub type Mat3 = nalgebra::Matrix3<f64>;
