//! The [`ScalarField`] trait: the extension point for the sensed environment.

use crate::config::Goal;
use vbap_math::{Mat3, Vec3};

use super::Field;

/// A scalar field T(x, t) with analytic derivatives: the extension point for the sensed
/// environment. The field server samples it ([`measure`](super::measure)), the recorder
/// judges the run by it (true gradient, true optimum, the plot's contours); every shipped
/// kind ([`Field`], from a mission's `[field]`) implements it, and so can a user's own (a
/// gridded data set, a model's output): hand it to the simulator, the field server and the
/// recorder instead of the mission's.
///
/// Units: positions in the mission's length unit, `t` mission time in s, values in the
/// field's unit. A 2-D field ignores z and returns zero z components.
pub trait ScalarField: Send + Sync + std::fmt::Debug {
    /// 2 or 3: the number of spatial dimensions the field depends on.
    fn dim(&self) -> usize;
    /// T(p, t) (field unit).
    fn value(&self, p: &Vec3, t: f64) -> f64;
    /// ∇T(p, t) (field unit per length unit).
    fn gradient(&self, p: &Vec3, t: f64) -> Vec3;
    /// ∇²T(p, t) (field unit per length unit²), symmetric.
    fn hessian(&self, p: &Vec3, t: f64) -> Mat3;
    /// The true optimum at time `t` (the maximum for `Goal::Max`, the minimum for
    /// `Goal::Min`), or `None` if there is none (or it is not known): the verdict then
    /// judges the formation only.
    fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        let _ = (t, goal);
        None
    }
    /// A box (lower, upper corner; length unit) around the interesting part of the field
    /// at t = 0, for plots (they union it with the tracks). Default: ±10 around the origin.
    fn bounds_hint(&self) -> (Vec3, Vec3) {
        let half = Vec3::new(10.0, 10.0, if self.dim() == 3 { 10.0 } else { 0.0 });
        (-half, half)
    }
}

impl ScalarField for Field {
    fn dim(&self) -> usize {
        Field::dim(self)
    }
    fn value(&self, p: &Vec3, t: f64) -> f64 {
        Field::value(self, p, t)
    }
    fn gradient(&self, p: &Vec3, t: f64) -> Vec3 {
        Field::gradient(self, p, t)
    }
    fn hessian(&self, p: &Vec3, t: f64) -> Mat3 {
        Field::hessian(self, p, t)
    }
    fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        Field::optimum(self, t, goal)
    }
    fn bounds_hint(&self) -> (Vec3, Vec3) {
        Field::bounds_hint(self)
    }
}
