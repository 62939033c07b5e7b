//! Currents: the water's velocity, which carries every vehicle (beyond the paper). A
//! vehicle controls its velocity through the water; over the ground it moves at that plus
//! the current ([`vbap_math::vehicle::advance`]).
//!
//! [`CurrentField`] is what the motion code asks of a current; [`AnalyticCurrent`] is
//! built from `[current]` by [`current_of`]; `current.kind = "grid"` reads u and v from a
//! file with the gridded-field reader ([`GridCurrent`]).

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

/// A gridded current (`current.kind = "grid"`): u and v interpolated from a file as a
/// gridded field is (C¹, their values only); w = 0. Over land (fill values) the grids hold
/// the nearby water's values, as a gridded field does.
#[derive(Clone, Debug)]
pub struct GridCurrent {
    /// The eastward / x velocity, length unit/s.
    pub u: Arc<crate::grid::GridField>,
    /// The northward / y velocity, length unit/s.
    pub v: Arc<crate::grid::GridField>,
}

impl CurrentField for GridCurrent {
    fn velocity(&self, p: &Vec3, t: f64) -> Vec3 {
        Vec3::new(self.u.value(p, t), self.v.value(p, t), 0.0)
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
        CurrentKind::None => None,
        CurrentKind::Grid => c.grid.0.as_ref().map(|[u, v]| {
            Arc::new(GridCurrent {
                u: Arc::clone(u),
                v: Arc::clone(v),
            }) as Arc<dyn CurrentField>
        }),
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

    /// The shipped ocean's u and v, read as a gridded current: the current at a point is
    /// the u and v grids' interpolants there, and every key of `[current]` is checked.
    #[test]
    fn a_gridded_current_reads_u_and_v_of_a_file() {
        let missions = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions");
        let base = "[mission]\nname = \"g\"\n[field]\nkind = \"grid\"\nfile = \"ocean.nc\"\n\
             variable = \"temperature\"\norigin = [7.9, 43.9]\n";
        let origin = format!("{missions}/x.toml");
        let text = format!("{base}[current]\nkind = \"grid\"\nfile = \"ocean.nc\"\n");
        let m = Mission::from_toml_str(&text, &origin).unwrap_or_else(|e| panic!("{e}"));
        let current = current_of(&m).expect("a gridded current");
        let [u, v] = m.current.grid.0.clone().expect("u and v loaded");
        assert_eq!(u.variable, "u");
        assert_eq!(v.variable, "v");
        let p = Vec3::new(3000.0, -2000.0, 0.0);
        let c = current.velocity(&p, 0.0);
        assert_eq!(c, Vec3::new(u.value(&p, 0.0), v.value(&p, 0.0), 0.0));
        assert!(c.norm() > 0.0 && c.norm() < 2.0, "a sea current, m/s: {c}");
        for (extra, key) in [
            ("[current]\nkind = \"grid\"\n", "current.file"),
            (
                "[current]\nkind = \"grid\"\nfile = \"none.nc\"\n",
                "current.file",
            ),
            (
                "[current]\nkind = \"grid\"\nfile = \"ocean.nc\"\nu = \"w\"\n",
                "current.file",
            ),
            (
                "[current]\nkind = \"uniform\"\nvelocity = [0.1, 0.0]\nu = \"u\"\n",
                "current.u",
            ),
        ] {
            let err = Mission::from_toml_str(&format!("{base}{extra}"), &origin)
                .expect_err(extra)
                .to_string();
            assert!(err.contains(key), "{extra}: {err}");
        }
    }
}
