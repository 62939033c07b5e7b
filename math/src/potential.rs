//! Artificial pair potentials of Section II (Fig. 2): the inter-vehicle potential `V_I` and
//! the vehicle–virtual-leader potential `V_h` of (II.1) and (II.2).
//!
//! Both use the form of Leonard and Fiorelli (2001): the force between two points a
//! distance `x` apart is `f(x) = alpha (1/x − d0/x²)` (positive = attractive), repelling
//! below the equilibrium distance `d0`, attracting above it, and zero beyond the cut-off
//! `d1`. Here the force is additionally tapered smoothly to zero just below `d1` so that it
//! is continuous (see [`PairPotential`] for the exact taper).
//!
//! The potentials are scale invariant (III.3): scaling `d0` and `d1` by `k` gives
//! `f_k(x) = f(x/k)/k` and `V_k(x) = V(x/k)`, so the depth of every well and the plateau
//! height do not change when the formation expands or contracts, and
//! `∂V_k(x)/∂k = −(x/k) f_k(x)`.

use serde::{Deserialize, Serialize};

use super::Vec3;

/// Why a [`PairPotential`] is unusable.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PotentialError {
    /// `alpha` must be finite and > 0.
    #[error("potential strength alpha = {0} must be finite and > 0")]
    BadAlpha(f64),
    /// The distances must be finite with 0 < d0 < d1.
    #[error("potential distances must satisfy 0 < d0 < d1 (finite), got d0 = {d0}, d1 = {d1}")]
    BadDistances {
        /// Equilibrium distance given.
        d0: f64,
        /// Cut-off distance given.
        d1: f64,
    },
}

/// A Leonard–Fiorelli pair potential (Sec. II, Fig. 2; force used in (II.1), value in
/// (II.2)).
///
/// Force (positive = attractive), with `a = (d0 + d1)/2` the start of the taper and
/// `w = d1 − a = (d1 − d0)/2` its width:
///
/// - `0 < x < a`: `f(x) = alpha (1/x − d0/x²)`, the Leonard–Fiorelli force, untouched
///   (so `f(d0) = 0` and the equilibrium distance is exactly `d0`);
/// - `a ≤ x < d1`: the cubic Hermite taper, with `t = (x − a)/w`,
///   `f(x) = (1 − t)² [ f(a) (1 + 2t) + w f'(a) t ]`,
///   which matches the value and slope of the untapered force at `a` and has value and
///   slope 0 at `d1`. It stays > 0 (attractive) on the whole taper: the bracket is linear
///   in `t`, equal to `f(a) = alpha w/a² > 0` at `t = 0` and to
///   `3 f(a) + w f'(a) = alpha w (3 d0 + d1)/a³ > 0` at `t = 1`;
/// - `x ≥ d1`: `f(x) = 0`.
///
/// The force is therefore C¹ in `x` and the potential `V(x) = ∫_{d0}^{min(x, d1)} f` is C²,
/// `V ≥ 0` with its only zero at `x = d0`, non-increasing below `d0`, non-decreasing above,
/// and constant (= [`PairPotential::plateau`]) from `d1` on. `V(0) = +∞`.
///
/// Units: distances in the mission's length unit, `alpha` in (length/s)², so `f` is an
/// acceleration and `V` an energy per unit mass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairPotential {
    /// Strength, (length/s)². Must be > 0.
    pub alpha: f64,
    /// Equilibrium distance `d0` (`h0` for a leader potential), length. Must be > 0.
    pub d0: f64,
    /// Cut-off distance `d1` (`h1`), length: no force at or beyond it. Must be > `d0`.
    pub d1: f64,
}

impl PairPotential {
    /// A validated potential (Sec. II): `alpha > 0`, `0 < d0 < d1`, all finite.
    pub fn new(alpha: f64, d0: f64, d1: f64) -> Result<Self, PotentialError> {
        let p = Self { alpha, d0, d1 };
        p.validate()?;
        Ok(p)
    }

    /// Checks `alpha > 0` and `0 < d0 < d1`, all finite.
    pub fn validate(&self) -> Result<(), PotentialError> {
        if !(self.alpha.is_finite() && self.alpha > 0.0) {
            return Err(PotentialError::BadAlpha(self.alpha));
        }
        if !(self.d0.is_finite() && self.d1.is_finite() && self.d0 > 0.0 && self.d1 > self.d0) {
            return Err(PotentialError::BadDistances {
                d0: self.d0,
                d1: self.d1,
            });
        }
        Ok(())
    }

    /// Start of the taper `a = (d0 + d1)/2`, length. Below it the force is the pure
    /// Leonard–Fiorelli force.
    pub fn taper_start(&self) -> f64 {
        0.5 * (self.d0 + self.d1)
    }

    /// Untapered Leonard–Fiorelli force `alpha (x − d0)/x²` and its derivative in `x`.
    fn raw_force_and_slope(&self, x: f64) -> (f64, f64) {
        let x2 = x * x;
        (
            self.alpha * (x - self.d0) / x2,
            self.alpha * (2.0 * self.d0 - x) / (x2 * x),
        )
    }

    /// Untapered potential `alpha (ln(x/d0) + d0/x − 1)` for `0 < x`.
    fn raw_value(&self, x: f64) -> f64 {
        let u = (x - self.d0) / self.d0;
        self.alpha * (u.ln_1p() - u / (1.0 + u))
    }

    /// Force `f(x)` at distance `dist` (II.1), acceleration (length/s²); positive =
    /// attractive. `f(d0) = 0`, `f = 0` for `dist ≥ d1`, `f(0) = −∞` (a distance ≤ 0 is
    /// treated as 0).
    pub fn force(&self, dist: f64) -> f64 {
        if dist <= 0.0 {
            return f64::NEG_INFINITY;
        }
        if dist >= self.d1 {
            return 0.0;
        }
        let a = self.taper_start();
        if dist < a {
            return self.raw_force_and_slope(dist).0;
        }
        let w = self.d1 - a;
        let t = (dist - a) / w;
        let (fa, dfa) = self.raw_force_and_slope(a);
        let one_t = 1.0 - t;
        one_t * one_t * (fa * (1.0 + 2.0 * t) + w * dfa * t)
    }

    /// Potential `V(x) = ∫_{d0}^{min(x, d1)} f` (II.2), energy per unit mass
    /// (length²/s²). `V ≥ 0`, `V(d0) = 0`, `V = plateau()` for `dist ≥ d1`, `V(0) = +∞`.
    pub fn value(&self, dist: f64) -> f64 {
        if dist <= 0.0 {
            return f64::INFINITY;
        }
        let a = self.taper_start();
        if dist < a {
            return self.raw_value(dist);
        }
        let w = self.d1 - a;
        let t = ((dist - a) / w).min(1.0);
        let (fa, dfa) = self.raw_force_and_slope(a);
        // ∫_0^t (1−τ)²(1+2τ) dτ and ∫_0^t τ(1−τ)² dτ.
        let t2 = t * t;
        let i00 = t - t2 * t + 0.5 * t2 * t2;
        let i10 = 0.5 * t2 - 2.0 / 3.0 * t2 * t + 0.25 * t2 * t2;
        self.raw_value(a) + w * (fa * i00 + w * dfa * i10)
    }

    /// [`PairPotential::value`] given its [`PairPotential::plateau`] (computed once by a
    /// caller summing many pairs): the plateau itself at or beyond the cut-off `d1`, the
    /// same bits as `value(dist)` there (`t` of the taper is exactly 1 for every
    /// `dist ≥ d1 ≥ a`), without its square roots and divisions. Sums over all pairs (II.2)
    /// so cost a distance and a compare for each pair beyond the cut-off.
    #[inline]
    pub fn value_or_plateau(&self, dist: f64, plateau: f64) -> f64 {
        if dist >= self.d1 && self.taper_start() <= self.d1 {
            plateau
        } else {
            self.value(dist)
        }
    }

    /// Height of the plateau `V(d1)`, energy per unit mass: what a pair at or beyond the
    /// cut-off contributes to (II.2). Proportional to `alpha`; invariant under
    /// [`PairPotential::scaled`].
    pub fn plateau(&self) -> f64 {
        self.value(self.d1)
    }

    /// The potential of the virtual body scaled by `k` (III.3): `d_i(s) = k d̄_i`,
    /// `alpha` unchanged.
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            alpha: self.alpha,
            d0: k * self.d0,
            d1: k * self.d1,
        }
    }

    /// `∂/∂k value(dist)` of `self.scaled(k)` at `k = 1`, energy per unit mass (for
    /// `∂V/∂s` in Sec. IV through `k(s)` of (III.3)).
    ///
    /// Scale invariance `V_k(x) = V(x/k)` gives exactly `−dist · force(dist)`; for the
    /// derivative at another scale `k`, use `self.scaled(k).d_value_d_scale(x) / k`.
    /// `+∞` at `dist = 0`.
    pub fn d_value_d_scale(&self, dist: f64) -> f64 {
        if dist <= 0.0 {
            return f64::INFINITY;
        }
        -dist * self.force(dist)
    }
}

/// Potential part of (II.2): `Σ_{i<j} V_I(|x_i − x_j|) + Σ_i Σ_l V_h(|x_i − b_l|)`, energy
/// per unit mass (each unordered pair once, which is the `½ Σ_i Σ_{j≠i}` of (II.2)).
/// Summed in index order. `+∞` if two positions coincide.
pub fn potential_energy(
    positions: &[Vec3],
    leaders: &[Vec3],
    inter: &PairPotential,
    leader: &PairPotential,
) -> f64 {
    let mut e = 0.0;
    let plateau = inter.plateau();
    for (i, x) in positions.iter().enumerate() {
        for y in &positions[i + 1..] {
            e += inter.value_or_plateau((x - y).norm(), plateau);
        }
        for b in leaders {
            e += leader.value((x - b).norm());
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn value_or_plateau_is_value_bit_for_bit() {
        for p in [
            PairPotential::new(60.0, 0.87, 1.3).unwrap(),
            PairPotential::new(1.0, 1.0, 1.5).unwrap(),
            PairPotential::new(3.0, 2.0, 8.0).unwrap().scaled(0.73),
        ] {
            let plateau = p.plateau();
            let mut dists = samples(&p);
            dists.extend([p.d1, p.d1 * (1.0 + f64::EPSILON), 1e9, f64::INFINITY]);
            for d in dists {
                assert_eq!(
                    p.value_or_plateau(d, plateau).to_bits(),
                    p.value(d).to_bits(),
                    "{p:?} at {d}"
                );
            }
        }
    }

    fn samples(p: &PairPotential) -> Vec<f64> {
        (1..400)
            .map(|i| p.d1 * 1.3 * f64::from(i) / 400.0)
            .collect()
    }

    fn potentials() -> Vec<PairPotential> {
        vec![
            PairPotential::new(1.0, 1.0, 1.5).unwrap(),
            PairPotential::new(2.5, 1.41, 1.71).unwrap(),
            PairPotential::new(0.3, 0.2, 3.0).unwrap(),
            PairPotential::new(1.0, 1.0, 1.0001).unwrap(),
        ]
    }

    #[test]
    fn validation_rejects_bad_parameters() {
        assert!(PairPotential::new(0.0, 1.0, 2.0).is_err());
        assert!(PairPotential::new(f64::NAN, 1.0, 2.0).is_err());
        assert!(PairPotential::new(1.0, 0.0, 2.0).is_err());
        assert!(PairPotential::new(1.0, 2.0, 2.0).is_err());
        assert!(PairPotential::new(1.0, 1.0, f64::INFINITY).is_err());
        assert!(PairPotential::new(1.0, 1.0, 2.0).is_ok());
    }

    #[test]
    fn leonard_fiorelli_force_below_taper_and_zero_beyond_cutoff() {
        let p = PairPotential::new(2.0, 1.0, 2.0).unwrap();
        for x in [0.2, 0.5, 1.0, 1.3, 1.49] {
            assert_relative_eq!(
                p.force(x),
                2.0 * (1.0 / x - 1.0 / (x * x)),
                max_relative = 1e-14
            );
        }
        assert_eq!(p.force(1.0), 0.0);
        assert!(p.force(0.9) < 0.0 && p.force(1.1) > 0.0);
        assert_eq!(p.force(2.0), 0.0);
        assert_eq!(p.force(7.0), 0.0);
        assert_eq!(p.force(0.0), f64::NEG_INFINITY);
    }

    #[test]
    fn force_is_continuous_and_attractive_on_the_taper() {
        for p in potentials() {
            let a = p.taper_start();
            let eps = 1e-9 * p.d1;
            assert_relative_eq!(p.force(a - eps), p.force(a + eps), epsilon = 1e-7 * p.alpha);
            assert!(p.force(p.d1 - eps).abs() < 1e-7 * p.alpha);
            for x in samples(&p) {
                if x > p.d0 && x < p.d1 {
                    assert!(p.force(x) > 0.0, "{p:?} x={x}");
                }
            }
        }
    }

    #[test]
    fn value_is_the_integral_of_force() {
        for p in potentials() {
            for x in samples(&p) {
                let h = 1e-6 * x;
                let fd = (p.value(x + h) - p.value(x - h)) / (2.0 * h);
                assert_relative_eq!(
                    fd,
                    p.force(x),
                    epsilon = 1e-6 * p.alpha / p.d0,
                    max_relative = 1e-6
                );
            }
        }
    }

    #[test]
    fn value_is_nonnegative_zero_at_d0_and_flat_beyond_d1() {
        for p in potentials() {
            assert!(p.value(p.d0).abs() < 1e-15);
            for x in samples(&p) {
                assert!(p.value(x) >= 0.0);
                if x >= p.d1 {
                    assert_eq!(p.value(x), p.plateau());
                }
            }
            assert!(p.plateau() > 0.0);
            assert_eq!(p.value(0.0), f64::INFINITY);
        }
        // Plateau of alpha=1, d0=1, d1=1.5 by hand: ln(1.25) + 0.8 − 1 + w (f_a/2 + w f'_a/12)
        // with w = 0.25, f_a = 0.25/1.5625 = 0.16, f'_a = 0.75/1.953125 = 0.384.
        let p = PairPotential::new(1.0, 1.0, 1.5).unwrap();
        let by_hand = 1.25f64.ln() - 0.2 + 0.25 * (0.08 + 0.25 * 0.384 / 12.0);
        assert_relative_eq!(p.plateau(), by_hand, max_relative = 1e-13);
    }

    #[test]
    fn scaling_is_an_exact_symmetry() {
        for p in potentials() {
            for k in [0.3, 0.9, 1.0, 2.7] {
                let q = p.scaled(k);
                assert_eq!(q.alpha, p.alpha);
                assert_relative_eq!(q.plateau(), p.plateau(), max_relative = 1e-12);
                for x in samples(&p) {
                    assert_relative_eq!(
                        q.value(k * x),
                        p.value(x),
                        epsilon = 1e-12 * p.alpha,
                        max_relative = 1e-12
                    );
                    assert_relative_eq!(
                        k * q.force(k * x),
                        p.force(x),
                        epsilon = 1e-12 * p.alpha,
                        max_relative = 1e-12
                    );
                }
            }
        }
    }

    #[test]
    fn d_value_d_scale_matches_finite_differences() {
        for p in potentials() {
            for x in samples(&p) {
                let h = 1e-6;
                let fd = (p.scaled(1.0 + h).value(x) - p.scaled(1.0 - h).value(x)) / (2.0 * h);
                assert_relative_eq!(
                    p.d_value_d_scale(x),
                    fd,
                    epsilon = 1e-6 * p.alpha,
                    max_relative = 1e-6
                );
            }
        }
    }
}
