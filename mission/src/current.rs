//! Currents: the water's velocity, which carries every vehicle (beyond the paper). A
//! vehicle controls its velocity through the water; over the ground it moves at that plus
//! the current ([`vbap_math::vehicle::advance`]).
//!
//! [`CurrentField`] is what the motion code asks of a current; [`AnalyticCurrent`] is
//! built from `[current]` by [`current_of`]. `current.kind = "grid"` is the slot for
//! gridded u, v (w) read from a file by the gridded-field reader: it is refused by
//! validation until that reader is wired here.

use std::sync::Arc;

use vbap_math::Vec3;

use crate::config::{CurrentKind, Mission};

/// A current: the velocity of the water at a point and time.
pub trait CurrentField: Send + Sync + std::fmt::Debug {
    /// Velocity of the water at `p` (length unit) and mission time `t` (s), length unit/s.
    fn velocity(&self, p: &Vec3, t: f64) -> Vec3;
}

/// The analytic currents of `[current]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalyticCurrent {
    /// `current.kind` (not `None`, not `Grid`).
    pub kind: CurrentKind,
    /// Background velocity, length unit/s.
    pub velocity: Vec3,
    /// Eddy centre / shear reference point, length unit.
    pub center: Vec3,
    /// Length unit.
    pub width: f64,
    /// Length unit/s.
    pub strength: f64,
    /// Tidal period, s (0: steady).
    pub period: f64,
}

impl CurrentField for AnalyticCurrent {
    fn velocity(&self, p: &Vec3, t: f64) -> Vec3 {
        let r = p - self.center;
        let local = match self.kind {
            CurrentKind::Eddy => {
                // Gaussian vortex: speed strength·(ρ/w)·exp(½ − ρ²/(2w²)), tangential.
                let w = self.width;
                let rho2 = r.x * r.x + r.y * r.y;
                let scale = self.strength / w * (0.5 - rho2 / (2.0 * w * w)).exp();
                Vec3::new(-r.y, r.x, 0.0) * scale
            }
            CurrentKind::Shear => Vec3::new(self.strength * r.y / self.width, 0.0, 0.0),
            _ => Vec3::zeros(),
        };
        let c = self.velocity + local;
        if self.period > 0.0 {
            c * (std::f64::consts::TAU * t / self.period).cos()
        } else {
            c
        }
    }
}

/// The current of `mission` (None: still water).
pub fn current_of(mission: &Mission) -> Option<Arc<dyn CurrentField>> {
    let c = &mission.current;
    let v = |x: &[f64]| {
        let mut out = Vec3::zeros();
        for (i, a) in x.iter().take(mission.mission.dim.min(3)).enumerate() {
            out[i] = *a;
        }
        out
    };
    match c.kind {
        CurrentKind::None | CurrentKind::Grid => None,
        kind => Some(Arc::new(AnalyticCurrent {
            kind,
            velocity: v(&c.velocity),
            center: v(&c.center),
            width: c.width,
            strength: c.strength,
            period: c.period,
        })),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_eddy_turns_counter_clockwise_and_peaks_at_its_width() {
        let e = AnalyticCurrent {
            kind: CurrentKind::Eddy,
            velocity: Vec3::zeros(),
            center: Vec3::new(10.0, 0.0, 0.0),
            width: 5.0,
            strength: 0.2,
            period: 0.0,
        };
        let at = e.velocity(&Vec3::new(15.0, 0.0, 0.0), 0.0);
        assert!((at - Vec3::new(0.0, 0.2, 0.0)).norm() < 1e-12);
        assert!(e.velocity(&Vec3::new(14.0, 0.0, 0.0), 0.0).norm() < 0.2);
        assert!(e.velocity(&Vec3::new(16.0, 0.0, 0.0), 0.0).norm() < 0.2);
        let tide = AnalyticCurrent {
            kind: CurrentKind::Uniform,
            velocity: Vec3::new(0.1, 0.0, 0.0),
            period: 100.0,
            ..e
        };
        assert!((tide.velocity(&Vec3::zeros(), 50.0).x + 0.1).abs() < 1e-12);
    }
}
