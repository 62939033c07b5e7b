//! The sensed environments, with ground truth, and the keyed sensor noise.
//!
//! A [`Field`] is the scalar field T(x, t) the vehicles measure (temperature in °C, say, over
//! positions in metres and mission time in seconds, or the paper's non-dimensional units). It
//! knows its own value, gradient, Hessian and optimum analytically: that is the *ground truth*
//! the evaluator and the recorder use, never the coordinator's estimator (docs/ARCHITECTURE.md §9).
//!
//! Positions are always [`Vec3`](vbap_math::Vec3). A 2-D field (`dim = 2`) is a function of
//! x and y only: the z component of a query point is ignored, and the z components of the
//! gradient and of the Hessian are exactly zero.
//!
//! Sensor noise is drawn from [`vbap_math::rng::keyed`] with the key (seed,
//! [`Stream::SensorNoise`](vbap_math::rng::Stream::SensorNoise), vehicle, tick), so the same
//! reading is noisy in exactly the same way in the in-process simulator and in the
//! multi-process system (docs/ARCHITECTURE.md §4).
//!
//! Files by concern: `kinds` (the shipped kinds and building one from a mission's
//! `[field]`), `eval` (value, gradient and Hessian), `optimum` (the true optimum),
//! `bounds` (the box a plot shows), `scalar_field` (the [`ScalarField`] trait, the
//! extension point), `noise` (the keyed sensor noise and a reading).

mod bounds;
mod eval;
mod kinds;
mod noise;
mod optimum;
mod scalar_field;
#[cfg(test)]
mod tests;

pub use kinds::{Field, GaussianBump};
pub use noise::{measure, sensor_noise};
pub use scalar_field::ScalarField;
