//! The sawtooth dive of a glider in a 3-D field (beyond the paper, whose vehicles move
//! freely in z): the glider flies down from the surface (z = 0) to z = `depth` and back up
//! at the vertical speed `rate` through the water, over and over, taking readings all along
//! the way; it is at the surface (where it gets its GPS fix) once per period
//! P = 2 |depth| / rate:
//!
//! z(t) = depth · tri(t / P), tri(φ) = 1 − |1 − 2 (φ mod 1)| ∈ [0, 1],
//! ż(t) = ± 2 depth / P (down on the first half-period, up on the second).

/// A sawtooth dive profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dive {
    /// z at the bottom of each dive (length unit, ≠ 0): positive on a depth axis that points
    /// down, negative on one that points up.
    pub depth: f64,
    /// Vertical speed through the water, length unit/s, > 0.
    pub rate: f64,
}

impl Dive {
    /// The period P = 2 |depth| / rate, s.
    pub fn period(&self) -> f64 {
        2.0 * self.depth.abs() / self.rate
    }

    /// The phase t / P mod 1 at time `t` (s).
    fn phase(&self, t: f64) -> f64 {
        (t / self.period()).rem_euclid(1.0)
    }

    /// z(t), length unit.
    pub fn z(&self, t: f64) -> f64 {
        self.depth * (1.0 - (1.0 - 2.0 * self.phase(t)).abs())
    }

    /// ż(t), length unit/s: towards `depth` on the way down, towards 0 on the way up.
    pub fn vz(&self, t: f64) -> f64 {
        let down = self.rate * self.depth.signum();
        if self.phase(t) < 0.5 {
            down
        } else {
            -down
        }
    }

    /// True when a glider diving from t = 0 is at the surface at tick `k` of length `dt`
    /// (s): the first tick of each period.
    pub fn at_surface(&self, k: u64, dt: f64) -> bool {
        let t = k as f64 * dt;
        k == 0 || t.rem_euclid(self.period()) < dt * (1.0 - 1e-9)
    }
}

#[cfg(test)]
mod tests {
    use super::Dive;

    #[test]
    fn the_profile_is_a_sawtooth_between_the_surface_and_the_dive_depth() {
        let d = Dive {
            depth: 100.0,
            rate: 0.5,
        };
        assert_eq!(d.period(), 400.0);
        assert_eq!(d.z(0.0), 0.0);
        assert_eq!(d.z(100.0), 50.0);
        assert_eq!(d.z(200.0), 100.0);
        assert_eq!(d.z(300.0), 50.0);
        assert_eq!(d.z(400.0), 0.0);
        assert_eq!((d.vz(50.0), d.vz(250.0)), (0.5, -0.5));
        // Integrating ż reproduces z.
        let (mut z, dt) = (0.0, 1.0);
        for k in 0..1000u64 {
            z += d.vz(k as f64 * dt) * dt;
            assert!((z - d.z((k + 1) as f64 * dt)).abs() < 1e-9, "tick {k}");
        }
        let up = Dive {
            depth: -60.0,
            rate: 0.2,
        };
        assert_eq!(up.z(300.0), -60.0);
        assert!(up.vz(10.0) < 0.0);
        let surfaced: Vec<u64> = (0..2000).filter(|k| d.at_surface(*k, 1.0)).collect();
        assert_eq!(surfaced, vec![0, 400, 800, 1200, 1600]);
    }
}
