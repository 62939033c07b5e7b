//! The soft barrier (beyond the paper): a one-sided spring that keeps two points apart
//! inside a short reach, with a stiffness bounded by the formation's own, used where
//! the law must keep a vehicle off something that may already be close: a neighbour that
//! rejoins ([`super::rejoin`]) and the hull of a lost vehicle ([`super::hull`]).
//!
//! `V_b(x) = ½ κ_b (R − x)²` for `x < R`, 0 beyond; force `κ_b (R − x)` pushing apart;
//! `κ_b = BARRIER_STIFFNESS · α/d0²` of the scaled inter-vehicle potential `V_I`
//! (`α/d0²` is `f'(d0)`, the stiffness of one neighbour spring), reach `R` a fraction
//! of `d0`. Both scale with the body as `V_I` does (`κ_b ∝ 1/k²`, `R ∝ k`), so
//! `V_b(x) = V_b(x/k)` at scale `k`, as (III.3) needs.
//!
//! Why not the repulsive part of `V_I` (`α (x − d0)/x²`, a `1/x` wall): a vehicle admitted
//! back where it died may find a member a quarter of a spacing away, and the wall's force
//! there (`≈ 2.4 α/d0` for a reach of half a spacing) moved both by 10–12 spacings per
//! second in one 0.05 s step (random missions: true V 14 V_U at the admission; the wall's
//! stiffness at a sixth of a spacing is a hundred times the formation's, far beyond what
//! the step integrates). The spring's force is at most `κ_b R`, its frequency
//! `√κ_b = 2 ω_pair` is within the time step's check wherever the formation's is
//! (`ω·dt ≤ 1`), and its energy is at most `½ κ_b R²`, a fraction of `α`.

use super::potential::PairPotential;
use super::Vec3;

/// The barrier's stiffness in units of one neighbour spring's, `α/d0²`.
pub const BARRIER_STIFFNESS: f64 = 4.0;

/// A soft barrier: reach `reach` (length) and stiffness `kappa` (1/s²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barrier {
    /// Distance beyond which it does nothing, length unit.
    pub reach: f64,
    /// Stiffness `κ_b`, 1/s² (acceleration per unit length of penetration).
    pub kappa: f64,
}

impl Barrier {
    /// The barrier of the scaled inter-vehicle potential `inter` reaching `reach` of its
    /// `d0` (module docs).
    pub fn of(inter: &PairPotential, reach: f64) -> Self {
        Self {
            reach: reach * inter.d0,
            kappa: BARRIER_STIFFNESS * inter.alpha / (inter.d0 * inter.d0),
        }
    }

    /// Adds to `u` the push `w κ_b (R − |x − p|) (x − p)/|x − p|` of the barrier round `p`
    /// felt at `x` (length/s²): nothing at or beyond the reach, at `p` itself (no
    /// direction) or for `w ≤ 0`.
    pub fn push(&self, u: &mut Vec3, x: &Vec3, p: &Vec3, w: f64) {
        if w.is_nan() || w <= 0.0 {
            return;
        }
        let d = x - p;
        let dist = d.norm();
        if dist > 0.0 && dist < self.reach {
            *u += (w * self.kappa * (self.reach - dist) / dist) * d;
        }
    }

    /// `V_b(dist)`, energy per unit mass: `½ κ_b (R − dist)²` inside the reach, else 0.
    pub fn value(&self, dist: f64) -> f64 {
        let pen = (self.reach - dist).max(0.0);
        0.5 * self.kappa * pen * pen
    }

    /// `∂/∂k V_b(dist)` of the barrier scaled by `k` (`R → k R`, `κ_b → κ_b/k²`) at
    /// `k = 1`, positions fixed: `−2 V_b + κ_b (R − dist) R` inside the reach, else 0 (the
    /// convention of `PairPotential::d_value_d_scale`).
    pub fn d_value_d_scale(&self, dist: f64) -> f64 {
        let pen = (self.reach - dist).max(0.0);
        -2.0 * self.value(dist) + self.kappa * pen * self.reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn barrier() -> Barrier {
        Barrier::of(&PairPotential::new(50.0, 2.0, 4.0).unwrap(), 0.5)
    }

    #[test]
    fn the_push_is_minus_the_gradient_of_the_value_and_ends_at_the_reach() {
        let b = barrier();
        assert_eq!(b.reach, 1.0);
        assert_eq!(b.kappa, 4.0 * 50.0 / 4.0);
        let p = Vec3::new(1.0, -2.0, 0.5);
        for x in [0.05, 0.3, 0.7, 0.999] {
            let at = p + Vec3::new(0.6, 0.8, 0.0) * x;
            let mut u = Vec3::zeros();
            b.push(&mut u, &at, &p, 1.0);
            let h = 1e-6;
            let fd = -(b.value(x + h) - b.value(x - h)) / (2.0 * h);
            assert_relative_eq!(u.norm(), fd, max_relative = 1e-6);
            assert_relative_eq!(u.normalize(), Vec3::new(0.6, 0.8, 0.0), epsilon = 1e-12);
        }
        let mut u = Vec3::zeros();
        b.push(&mut u, &(p + Vec3::new(1.0, 0.0, 0.0)), &p, 1.0);
        b.push(&mut u, &p, &p, 1.0);
        b.push(&mut u, &(p + Vec3::new(0.1, 0.0, 0.0)), &p, 0.0);
        assert_eq!(u, Vec3::zeros());
        assert_eq!(b.value(1.0), 0.0);
    }

    #[test]
    fn d_value_d_scale_matches_finite_differences() {
        let inter = PairPotential::new(50.0, 2.0, 4.0).unwrap();
        for x in [0.05, 0.3, 0.7, 0.99, 1.5] {
            let h = 1e-6;
            let at = |k: f64| Barrier::of(&inter.scaled(k), 0.5).value(x);
            let fd = (at(1.0 + h) - at(1.0 - h)) / (2.0 * h);
            assert_relative_eq!(
                Barrier::of(&inter, 0.5).d_value_d_scale(x),
                fd,
                epsilon = 1e-5
            );
        }
    }
}
